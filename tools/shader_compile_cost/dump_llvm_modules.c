// LD_PRELOAD shim for Mesa's llvmpipe (lavapipe): writes every LLVM module llvmpipe hands to
// LLVMRunPasses into $DUMP_DIR as NNNNNN.ll (before the passes) and NNNNNN.opt.ll (after), with
// the pass pipeline in NNNNNN.passes, numbered in call order. The last .opt.ll of a module is
// what LLVM's code generator compiles. Used by compile_cost.sh.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

typedef void *LLVMModuleRef;
typedef void *LLVMErrorRef;

static LLVMErrorRef (*real_run)(LLVMModuleRef, const char *, void *, void *);
static int (*print_module)(LLVMModuleRef, const char *, char **);
static void (*dispose_message)(char *);
static int count;

static void dump(LLVMModuleRef m, const char *dir, int n, const char *suffix) {
    char path[4096];
    char *error = NULL;
    snprintf(path, sizeof path, "%s/%06d%s", dir, n, suffix);
    if (print_module(m, path, &error)) {
        fprintf(stderr, "dump_llvm_modules: %s: %s\n", path, error ? error : "cannot write");
    }
    if (error) {
        dispose_message(error);
    }
}

LLVMErrorRef LLVMRunPasses(LLVMModuleRef m, const char *passes, void *machine, void *options) {
    if (!real_run) {
        // libLLVM is loaded by the Vulkan driver, privately: look it up by name, not RTLD_NEXT.
        void *llvm = dlopen("libLLVM-15.so.1", RTLD_NOLOAD | RTLD_LAZY);
        if (!llvm) {
            fprintf(stderr, "dump_llvm_modules: libLLVM-15.so.1 is not loaded\n");
            abort();
        }
        real_run = dlsym(llvm, "LLVMRunPasses");
        print_module = dlsym(llvm, "LLVMPrintModuleToFile");
        dispose_message = dlsym(llvm, "LLVMDisposeMessage");
    }
    const char *dir = getenv("DUMP_DIR");
    // llvmpipe may compile on more than one thread: each call keeps its own number.
    int n = __atomic_add_fetch(&count, 1, __ATOMIC_RELAXED);
    if (dir) {
        dump(m, dir, n, ".ll");
        char path[4096];
        snprintf(path, sizeof path, "%s/%06d.passes", dir, n);
        FILE *f = fopen(path, "w");
        if (f) {
            fputs(passes, f);
            fclose(f);
        }
    }
    LLVMErrorRef result = real_run(m, passes, machine, options);
    if (dir) {
        dump(m, dir, n, ".opt.ll");
    }
    return result;
}
