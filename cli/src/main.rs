//! The `raytree` command: render, trace ray files, inspect structures.

// Counts live heap bytes, for the builds' peak memory in the reports.
#[global_allocator]
static HEAP: raytree_cli::meter::Metered = raytree_cli::meter::Metered;

fn main() -> std::process::ExitCode {
    raytree_cli::cli::main()
}
