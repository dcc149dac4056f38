//! The `stickslip` binary: parse, run, and map any error to one `error:` line.

use std::process::ExitCode;

fn main() -> ExitCode {
    stickslip::cli::main()
}
