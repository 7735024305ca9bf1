//! `penumbra`: the command-line entry point. Subcommands: `view` (interactive window), `render`
//! (headless screenshot), `bench` (CPU/GPU timings), `gif` (turntable), `report`
//! (error against path-traced references and cost, per quality preset). The binary adds no rendering features of its
//! own; it wires the engine and renderer to a window or a file.

mod cli;
mod commands;
mod scene;
mod view;

use std::io::IsTerminal;
use std::process::ExitCode;

use clap::Parser;

/// A headless command needs no display, and must not go looking for one: Mesa's Vulkan
/// device-select layer connects to the Wayland display named in the environment to rank GPUs,
/// and libwayland prints "error: XDG_RUNTIME_DIR is invalid or not set in the environment."
/// where there is none (a CI job, `ssh` from a desktop session). Penumbra ranks adapters itself.
/// A file-size limit (`ulimit -f`) becomes a write error (EFBIG) that names the file, instead of
/// a SIGXFSZ that kills the process with a partial file behind it.
///
/// # Safety
/// Changes the process environment and a signal disposition: call before any other thread.
unsafe fn run_headless() {
    for var in ["WAYLAND_DISPLAY", "WAYLAND_SOCKET", "DISPLAY"] {
        // SAFETY: the caller guarantees no other thread reads the environment.
        unsafe { std::env::remove_var(var) };
    }
    #[cfg(unix)]
    // SAFETY: ignoring a signal has no preconditions.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(if args.verbose { "info" } else { "warn" })),
        )
        .with_writer(std::io::stderr)
        // Colour only for a person at a terminal, and never where NO_COLOR is set (no-color.org).
        .with_ansi(std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty()))
        .init();
    if !args.command.opens_window() {
        // SAFETY: no other thread exists yet, and no GPU instance.
        unsafe { run_headless() };
    }
    // SAFETY: no other thread exists yet, and no GPU instance.
    let watches_shaders = args.command.watches_shaders();
    if let Some(applied) = unsafe { args.cpu_shader_compile.mode(watches_shaders).apply() } {
        let why = if args.cpu_shader_compile == cli::CpuCompileArg::Auto {
            " while shaders are watched; `--cpu-shader-compile optimized` for faster frames"
        } else {
            ""
        };
        tracing::info!("CPU rasteriser shaders compile without optimisation ({applied}){why}");
    }
    let result = match args.command {
        cli::Command::Render(a) => commands::render::run(a),
        cli::Command::Bench(a) => commands::bench::run(a),
        cli::Command::View(a) => view::run(a),
        cli::Command::Gif(a) => commands::gif::run(a),
        cli::Command::Report(a) => commands::report::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("penumbra: {e:#}");
            ExitCode::FAILURE
        }
    }
}
