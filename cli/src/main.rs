//! The `raytree` command: render, trace ray files, inspect structures.

fn main() -> std::process::ExitCode {
    raytree_cli::cli::main()
}
