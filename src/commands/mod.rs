//! One module per subcommand: read the inputs, call the library, write the outputs.

mod animate;
mod bake;
mod compare;
mod export;
mod inspect;
mod place;
mod render;
mod temporal;

pub use compare::{TOO_DIFFERENT, TooDifferent};

use crate::cli::{Cli, Command};

pub fn run(cli: Cli) -> anyhow::Result<()> {
    if let Some(asked) = cli.threads {
        let cores = std::thread::available_parallelism().ok();
        let n = usable_threads(asked as usize, cores);
        if n < asked as usize {
            warn(&format!(
                "--threads {asked}: this machine runs {} at once; using {n} (the output is the \
                 same for any number, and hundreds of threads on a few cores only wait on \
                 each other)",
                cores.map_or(1, |c| c.get())
            ));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()?;
    }
    texel_forest::output::remove_temporaries_on_interrupt();
    let limits = cli.limits();
    match cli.command {
        Command::Bake(args) => bake::run(&args, &limits, cli.quiet),
        Command::Place(args) => place::run(&args, &limits, cli.quiet),
        Command::Render(args) => render::run(&args, &limits, cli.quiet),
        Command::Inspect(args) => inspect::run(&args, &limits),
        Command::Compare(args) => compare::run(&args, &limits),
        Command::Animate(args) => animate::run(&args, &limits, cli.quiet),
        Command::Export(args) => export::run(&args, &limits, cli.quiet),
    }
}

/// The worker threads to start when `asked` for on a machine that runs `cores` at once: at
/// most four per core (and never fewer than eight allowed). More make nothing faster, and far
/// more are much slower: each parallel step wakes every worker, and 1,024 of them took a
/// half-second bake to 65 s on two cores.
fn usable_threads(asked: usize, cores: Option<std::num::NonZeroUsize>) -> usize {
    let cores = cores.map_or(1, |c| c.get());
    asked.min((4 * cores).max(8))
}

/// Prints a warning the way every subcommand does (control characters from files escaped).
/// Further lines of a long warning are indented under its first.
pub fn warn(message: &str) {
    let lines: Vec<String> = message
        .lines()
        .map(texel_forest::inspect::printable)
        .collect();
    to_stderr(&format!("texel: warning: {}", lines.join("\n    ")));
}

/// Prints a run's summary line (control characters from files escaped, as in warnings).
pub fn summary(message: &str) {
    to_stderr(&format!(
        "texel: {}",
        texel_forest::inspect::printable(message)
    ));
}

/// Writes one line to standard error. A standard error that cannot be written (a closed pipe,
/// `2>&1 | head -1`, a full disk) loses the line but not the run's exit status, where
/// `eprintln!` would panic (exit 101).
pub fn to_stderr(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// Writes to standard output; a reader that stops early (`| head`) is not an error.
pub fn print(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}

/// The directory a file will be written in ("." for a bare name).
pub fn directory_of(output: &std::path::Path) -> std::path::PathBuf {
    match output.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    }
}

#[cfg(test)]
mod tests {
    use super::usable_threads;
    use std::num::NonZeroUsize;

    #[test]
    fn threads_are_capped_at_four_a_core_but_never_below_eight() {
        let cores = |n| NonZeroUsize::new(n);
        assert_eq!(usable_threads(1024, cores(2)), 8);
        assert_eq!(usable_threads(3, cores(2)), 3);
        assert_eq!(usable_threads(1024, cores(64)), 256);
        assert_eq!(usable_threads(100, None), 8);
    }
}
