//! How much work and memory one input may ask for. Our formats and glTF can describe far more
//! than any tree or forest needs: a 65 KB file can claim gigabytes once decompressed or
//! instanced. Every reader checks what a file asks for against these limits before it
//! allocates, and says which flag raises the limit.

/// The limits a run works within. The defaults hold every real asset with room to spare.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Cells of one texture, all mip levels (`--max-cells`).
    pub cells: u64,
    /// Triangles of one glTF scene once every node is instanced (`--max-triangles`).
    pub triangles: u64,
    /// Trees of one forest (`--max-trees`).
    pub trees: u64,
    /// Pixels of one image, read or written, and of a glTF's images together
    /// (`--max-pixels`).
    pub pixels: u64,
    /// Trees standing over one tree's base, itself included, in a forest to render
    /// (`--max-overlap`; `render::crowding`).
    pub overlap: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            // 4.2 million: a 160^3 texture and its mips, about 330 MiB in memory (80 bytes a
            // cell); the default bake (32 cells) makes 37,000, and a 65 KB file of zeros that
            // claims 300^3 cells (4.8 GB once read) is refused. `--max-cells` lets the bake
            // go to its largest, 256^3 (19.2 million).
            cells: 1 << 22,
            // 16.8 million: a hundred detailed trees in one file.
            triangles: 1 << 24,
            // 16.8 million: sixteen times the million-tree benchmark.
            trees: 1 << 24,
            // 268 million: 16k x 16k.
            pixels: 1 << 28,
            // `place`'s forests have a few dozen at most (the demo's 31); trees a metre apart in
            // boxes 10 m across about 160. A pile of 100,000 trees on one spot took a 64 x 36
            // render 9 s, about 40 ns a tree for each pixel that sees it.
            overlap: 1 << 10,
        }
    }
}

/// What went over which limit.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{what} is {value}, over the limit of {limit} (raise it with {flag})")]
pub struct LimitError {
    pub what: String,
    pub value: u64,
    pub limit: u64,
    pub flag: &'static str,
}

impl Limits {
    fn check(value: u64, limit: u64, what: &str, flag: &'static str) -> Result<(), LimitError> {
        if value > limit {
            return Err(LimitError {
                what: what.to_string(),
                value,
                limit,
                flag,
            });
        }
        Ok(())
    }

    pub fn check_cells(&self, cells: u64, what: &str) -> Result<(), LimitError> {
        Self::check(cells, self.cells, what, "--max-cells")
    }

    pub fn check_triangles(&self, triangles: u64, what: &str) -> Result<(), LimitError> {
        Self::check(triangles, self.triangles, what, "--max-triangles")
    }

    pub fn check_trees(&self, trees: u64, what: &str) -> Result<(), LimitError> {
        Self::check(trees, self.trees, what, "--max-trees")
    }

    pub fn check_pixels(&self, pixels: u64, what: &str) -> Result<(), LimitError> {
        Self::check(pixels, self.pixels, what, "--max-pixels")
    }

    pub fn check_overlap(&self, trees: u64, what: &str) -> Result<(), LimitError> {
        Self::check(trees, self.overlap, what, "--max-overlap")
    }
}

/// Work that needs more memory than this machine gives.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{what} needs {bytes} bytes of memory, more than this machine can give")]
pub struct MemoryError {
    pub what: String,
    pub bytes: u64,
}

/// Refuses work whose memory (`bytes`) this machine cannot give, probed by reserving it and
/// freeing it at once: a size that a raised limit lets through then fails with a message
/// before any work, instead of aborting the process once the work is done. (Memory the system
/// overcommits may still run out later; this catches what it refuses outright.)
pub fn check_memory(bytes: u64, what: &str) -> Result<(), MemoryError> {
    let refused = || MemoryError {
        what: what.to_string(),
        bytes,
    };
    let n = usize::try_from(bytes).map_err(|_| refused())?;
    let mut probe: Vec<u8> = Vec::new();
    probe.try_reserve_exact(n).map_err(|_| refused())
}

/// The most memory this process has held so far (its peak resident set), where the system
/// says (Linux: `VmHWM` of `/proc/self/status`); `None` elsewhere.
pub fn peak_memory() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}
