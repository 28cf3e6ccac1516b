//! Command-line front end. Failures print one line on stderr and exit 1;
//! usage errors exit 2 (clap's convention); an interrupt (Ctrl-C) removes
//! the files being written, prints one line and exits 130 (128 + SIGINT).

mod bench;
mod build;
mod common;
mod gpu;
mod info;
mod out;
mod render;
mod trace;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

/// Ray-tracing acceleration structures: build, trace, compare and measure
/// them on real scenes.
#[derive(Parser)]
#[command(name = "raytree", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene with ambient occlusion or path tracing to PNG (or
    /// JPEG, PPM, EXR).
    Render(render::RenderArgs),
    /// Trace a file of rays through a structure and write the hits.
    Trace(trace::TraceArgs),
    /// Describe a scene, its BVH and every available structure.
    Info(info::InfoArgs),
    /// Build a structure and save it, with its BVH and scene, to a file
    /// that trace, render and info load in place of the scene
    /// (-s file.rtree).
    Build(build::BuildArgs),
    /// Reproduce the papers' measurements.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
}

/// Every option that takes a value takes a negative number as its value,
/// so that its parser says what is wrong with it (`--width -5`: "-5 is not
/// in 1..=16384") rather than clap taking it for an unknown flag.
fn negative_numbers_are_values(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| {
        if a.get_action().takes_values() && !a.is_positional() {
            a.allow_negative_numbers(true)
        } else {
            a
        }
    })
    .mut_subcommands(negative_numbers_are_values)
}

fn parse_cli() -> Cli {
    let matches = negative_numbers_are_values(Cli::command()).get_matches();
    Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
}

pub fn main() -> ExitCode {
    let cli = parse_cli();
    // Without a handler, Ctrl-C would leave a half-written temporary file.
    let _ = ctrlc::set_handler(|| {
        raytree::render::remove_unfinished_files();
        eprintln!("raytree: interrupted; unfinished output files removed");
        std::process::exit(130);
    });
    // A bad memory limit or SIMD path is refused before any work.
    let result = raytree::scene::memory::available_bytes()
        .and_then(|_| raytree::structures::simd::from_env())
        .and_then(|forced| forced.map_or(Ok(()), raytree::structures::simd::set_active))
        .and_then(|_| match cli.command {
            Command::Render(a) => render::run(a),
            Command::Trace(a) => trace::run(a),
            Command::Info(a) => info::run(a),
            Command::Build(a) => build::run(a),
            Command::Bench(c) => bench::run(c),
        });
    match result {
        // Its line is already on stderr.
        Ok(()) if out::failed() => ExitCode::FAILURE,
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the cause, with file and line or limit where known.
            eprintln!("raytree: error: {}", e.to_string().replace('\n', " "));
            ExitCode::FAILURE
        }
    }
}
