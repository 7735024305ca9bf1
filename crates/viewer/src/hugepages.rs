//! Transparent huge pages for glibc's malloc, by re-executing once with a tunable set.
//!
//! Loading a textured model touches hundreds of megabytes of fresh memory: decoded images,
//! wgpu's staging copies and, on a software rasteriser, the textures themselves. Faulting that in
//! 4 KiB pages dominated `penumbra render` on lavapipe: DamagedHelmet at 512² took 99 k minor
//! page faults and 0.6 s; with `GLIBC_TUNABLES=glibc.malloc.hugetlb=1` (glibc ≥ 2.35 madvises its
//! heap for transparent huge pages) it took 15 k faults and 0.45 s (measured with
//! `/usr/bin/time -f "%e s %R"` on the 2-core CI machine). glibc reads tunables only at process
//! start, so the binary sets the variable and re-executes itself, unless the user already set
//! `GLIBC_TUNABLES` or asked not to with `PENUMBRA_NO_REEXEC=1`. If the re-exec fails, the run
//! simply continues in this process.

#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub fn enable() {
    use std::os::unix::process::CommandExt;
    if std::env::var_os("GLIBC_TUNABLES").is_some() || std::env::var_os("PENUMBRA_NO_REEXEC").is_some() {
        return;
    }
    let Ok(exe) = std::env::current_exe() else { return };
    let error = std::process::Command::new(exe)
        .args(std::env::args_os().skip(1))
        .env("GLIBC_TUNABLES", "glibc.malloc.hugetlb=1")
        .exec();
    tracing::debug!("re-executing with huge pages failed ({error}); continuing without");
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn enable() {}
