//! Counter-based random numbers: every draw is a pure function of a key (seed, stream, index),
//! so results never depend on thread scheduling or on the order work is done in.

/// What each random draw is for. Every stream of the program is keyed by one of these (most
/// spell their purpose in ASCII), so that no two purposes share numbers and a reader can see
/// at a glance which draws are which. The values are part of the output: changing one changes
/// forests and images.
pub mod purpose {
    // Baking.
    /// Whether an alpha-blended surface stops a scan ray.
    pub const BAKE_BLEND: u64 = 0x626c_656e_6473;
    /// Whether an alpha-blended surface stops a ray of the directional calibration.
    pub const CALIBRATION: u64 = 0x0063_616c_6962;
    /// Which foliage samples of a self-shadowing view ray carry its depth towards the sun.
    pub const SELF_SHADOW: u64 = 0x7365_6c66;
    // Placement.
    /// A band's own stream of darts.
    pub const BAND: u64 = 0x6261_6e64;
    /// Growth: darts in the annulus around a tree.
    pub const GROW: u64 = 0x6772_6f77;
    /// Which active tree grows next.
    pub const PICK: u64 = 0x7069_636b;
    /// The gap scan's darts.
    pub const SCAN: u64 = 0x7363_616e;
    /// A dart's species, height, rotation and variation.
    pub const SPECIES: u64 = 0x7370_6563;
    pub const HEIGHT: u64 = 0x6865_6967;
    pub const ROTATION: u64 = 0x726f_7461;
    pub const VARIATION: u64 = 0x7661_7269;
    // Rendering: `hash3(pixel key, sample, 0)` keys a sample; its ray's key is mixed from it.
    /// A pixel's stream: `hash3(seed, y << 32 | x, PIXEL)`.
    pub const PIXEL: u64 = 0x0070_6978;
    /// A frame of a sequence: its seed.
    pub const FRAME: u64 = 0x0066_7261_6d65;
    /// XOR-ed into a sample's key to key its ray.
    pub const RAY: u64 = 0x5a;
    /// Per view-ray segment `hash3(ray key, segment, ..)`: where in the segment the sample is,
    /// and its shadow ray's own stream.
    pub const SEGMENT_JITTER: u64 = 0x72;
    pub const SEGMENT_LIGHT: u64 = 0x6c;
    /// The leaf normal a segment's foliage is shaded with (`render::leaves`).
    pub const SEGMENT_LEAF: u64 = 0x6c66;
    /// Which part of a segment's mixture (wood or foliage) scatters its light.
    pub const SEGMENT_PART: u64 = 0x7061;
    /// Whether a view ray whose transmittance has fallen low goes on past a segment.
    pub const SEGMENT_GO_ON: u64 = 0x676f;
    /// A view ray's own draws, `hash3(ray key, 0, ..)` with these, which no segment purpose
    /// equals (a segment index in the middle slot once made the ground's stream that of
    /// segment 103): the offset of the stratified roulette that decides which of its samples
    /// cast a shadow ray (`render::sunlight::Strata`), and the terrain hit's shadow ray.
    pub const RAY_ROULETTE: u64 = 0x7374_7261;
    pub const GROUND_LIGHT: u64 = 0x6772_6c69;
    /// The mesh method: a ray's shadow stream (XOR-ed into its key), which leaves a tree keeps
    /// at a partial leaf fraction, and alpha-blended triangles.
    pub const MESH_SHADOW: u64 = 0x73;
    pub const MESH_LEAF: u64 = 0x6c65_6166;
    pub const MESH_BLEND: u64 = 0x7472_6163_6564;
    /// The hybrid method: whether a sample draws an instance (`hash3(sample key, instance,
    /// ..)`) from its texture or its polygon model, inside the transition band.
    pub const LOD: u64 = 0x006c_6f64;
    // Measurement (accuracy report, tests).
    pub const SILHOUETTE_PIXEL: u64 = 0x0073_696c;
    pub const SILHOUETTE_DIRECTION: u64 = 0x0064_6972;
    pub const SILHOUETTE_AXIS: u64 = 0x6178_6973;
}

/// SplitMix64's finaliser: a bijective 64-bit mix with full avalanche.
pub fn mix64(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// A 64-bit hash of three keys.
pub fn hash3(a: u64, b: u64, c: u64) -> u64 {
    mix64(
        a ^ mix64(
            b.wrapping_add(0x9e37_79b9_7f4a_7c15) ^ mix64(c.wrapping_add(0x632b_e59b_d9b4_e019)),
        ),
    )
}

/// Uniform in [0, 1) from the top 53 bits.
pub fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A stream of draws for one keyed purpose (a tree, a pixel...): draw `i` is `hash3(key, i)`.
#[derive(Clone, Debug)]
pub struct Stream {
    seed: u64,
    key: u64,
    counter: u64,
}

impl Stream {
    pub fn new(seed: u64, key: u64) -> Stream {
        Stream {
            seed,
            key,
            counter: 0,
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        self.counter += 1;
        hash3(self.seed, self.key, self.counter)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        unit(self.next_u64())
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_draws_are_uniform_enough() {
        let mut s = Stream::new(1, 2);
        let n = 100_000;
        let mut bins = [0u32; 10];
        for _ in 0..n {
            let x = s.unit();
            assert!((0.0..1.0).contains(&x));
            bins[(x * 10.0) as usize] += 1;
        }
        for b in bins {
            assert!((b as f64 - n as f64 / 10.0).abs() < 500.0, "{bins:?}");
        }
    }

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u64> = (0..4)
            .map({
                let mut s = Stream::new(7, 1);
                move |_| s.next_u64()
            })
            .collect();
        let b: Vec<u64> = (0..4)
            .map({
                let mut s = Stream::new(7, 1);
                move |_| s.next_u64()
            })
            .collect();
        let c: Vec<u64> = (0..4)
            .map({
                let mut s = Stream::new(7, 2);
                move |_| s.next_u64()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}

#[cfg(test)]
mod purposes {
    use super::purpose::*;

    /// The ray-level purposes share a ray key: none may equal another.
    #[test]
    fn ray_purposes_are_distinct() {
        let all = [
            SEGMENT_JITTER,
            SEGMENT_LIGHT,
            SEGMENT_LEAF,
            SEGMENT_PART,
            SEGMENT_GO_ON,
            RAY_ROULETTE,
            GROUND_LIGHT,
        ];
        for (i, a) in all.iter().enumerate() {
            assert!(!all[i + 1..].contains(a), "{a:#x} twice");
        }
    }
}
