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
    /// Pixels of one image, read or written (`--max-pixels`).
    pub pixels: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            // A 256^3 texture (the bake's largest) and its mips: 19.2 million.
            cells: 1 << 25,
            // 16.8 million: a hundred detailed trees in one file.
            triangles: 1 << 24,
            // 16.8 million: sixteen times the million-tree benchmark.
            trees: 1 << 24,
            // 268 million: 16k x 16k.
            pixels: 1 << 28,
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
}
