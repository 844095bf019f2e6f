//! One module per subcommand: read the inputs, call the library, write the outputs.

mod bake;
mod compare;
mod inspect;
mod place;
mod render;

pub use compare::{TOO_DIFFERENT, TooDifferent};

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
        Command::Place(args) => place::run(&args, cli.quiet),
        Command::Render(args) => render::run(&args, cli.quiet),
        Command::Inspect(args) => inspect::run(&args),
        Command::Compare(args) => compare::run(&args),
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

/// The directory a file will be written in ("." for a bare name), created if missing.
pub fn output_dir(output: &std::path::Path) -> anyhow::Result<std::path::PathBuf> {
    use anyhow::Context;
    let dir = match output.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("cannot create directory {}", dir.display()))?;
    Ok(dir)
}
