//! The `gregvox` binary: everything lives in the library's `cli` module.
fn main() -> std::process::ExitCode {
    gregvox::cli::main()
}
