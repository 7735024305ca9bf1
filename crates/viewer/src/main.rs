//! `penumbra`: the command-line entry point. Subcommands: `view` (interactive window), `render`
//! (headless screenshot), `bench` (CPU/GPU timings), `gif` (turntable), `report`
//! (error against path-traced references and cost, per quality preset). The binary adds no rendering features of its
//! own; it wires the engine and renderer to a window or a file.

mod cli;
mod commands;
mod scene;
mod view;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(if args.verbose { "info" } else { "warn" })),
        )
        .with_writer(std::io::stderr)
        .init();
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
