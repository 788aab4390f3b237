//! The `nanopush` binary: a thin CLI over the library.

fn main() -> std::process::ExitCode {
    // First, while this is the only thread: the environment is changed.
    nanopush::vision::opencv_quiet::quiet_ffmpeg_for_this_process();
    nanopush::cli::main()
}
