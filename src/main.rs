//! `texel`: the command-line front of texel-forest. Parses, dispatches, reports.

mod cli;
mod commands;

use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = cli::Cli::parse();
    match commands::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // One line: the context chain joined, outermost first.
            // A cause that its error's own message already quotes is not repeated.
            let mut message: Vec<String> = Vec::new();
            for cause in e.chain().map(|c| c.to_string()) {
                if !message.last().is_some_and(|m| m.contains(&cause)) {
                    message.push(cause);
                }
            }
            // Build logs and scripts expect one line per error; names from files must not
            // reach the terminal as control sequences.
            let line = message.join(": ").replace('\n', " ");
            commands::to_stderr(&format!(
                "texel: error: {}",
                texel_forest::inspect::printable(&line)
            ));
            if e.is::<commands::TooDifferent>() {
                std::process::ExitCode::from(commands::TOO_DIFFERENT)
            } else {
                std::process::ExitCode::FAILURE
            }
        }
    }
}
