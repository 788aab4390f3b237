//! The `nanopush` binary: a thin CLI over the library.

fn main() -> std::process::ExitCode {
    nanopush::cli::main()
}
