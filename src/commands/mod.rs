//! One module per subcommand: read the inputs, call the library, write the outputs.

mod bake;
mod inspect;

use crate::cli::{Cli, Command};

pub fn run(cli: Cli) -> anyhow::Result<()> {
    if let Some(n) = cli.threads {
        if n == 0 {
            anyhow::bail!("--threads must be at least 1");
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()?;
    }
    match cli.command {
        Command::Bake(args) => bake::run(&args, cli.quiet),
        Command::Inspect(args) => inspect::run(&args),
    }
}

/// Prints a warning the way every subcommand does.
pub fn warn(message: &str) {
    eprintln!("texel: warning: {message}");
}

/// Writes to standard output; a reader that stops early (`| head`) is not an error.
pub fn print(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}
