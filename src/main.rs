//! The `hyperpbd` command line: run, plan, demo, info, scene.

mod cli;

use clap::Parser;

fn main() -> std::process::ExitCode {
    cli::exit_141_on_broken_pipe();
    let args = cli::Cli::parse();
    match cli::dispatch(args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::ExitCode::from(e.exit_code())
        }
    }
}
