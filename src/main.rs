//! The `raytree` command: render, trace ray files, inspect structures.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
