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
    /// Where the mesh's rays of the density fit fall in their squares, and whether an
    /// alpha-blended surface stops them.
    pub const REFINE: u64 = 0x7265_6669_6e65;
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
    /// The shifts of a view ray's sequences along it (`along`, indexed by segment), drawn once
    /// per ray as `hash3(ray key, 0, ..)`: where in its segment each sample is, which part of
    /// a segment's mixture (wood or foliage) scatters its light, and the leaf normal its
    /// foliage is shaded with (`render::leaves`).
    pub const SEGMENT_JITTER: u64 = 0x72;
    pub const SEGMENT_PART: u64 = 0x7061;
    pub const SEGMENT_LEAF: u64 = 0x6c66;
    /// Per view-ray segment (from 1), `hash3(ray key, segment, ..)`: its shadow ray's own
    /// stream, and whether a view ray whose transmittance has fallen low goes on past it.
    pub const SEGMENT_LIGHT: u64 = 0x6c;
    pub const SEGMENT_GO_ON: u64 = 0x676f;
    /// More of a view ray's own draws, `hash3(ray key, 0, ..)` with these, which no segment
    /// purpose equals (a segment index in the middle slot once made the ground's stream that
    /// of segment 103): the offset of the stratified roulette that decides which of its
    /// samples cast a shadow ray (`render::sunlight::Strata`), and the terrain hit's shadow
    /// ray.
    pub const RAY_ROULETTE: u64 = 0x7374_7261;
    pub const GROUND_LIGHT: u64 = 0x6772_6c69;
    /// The shadow ray of a texture's solid surface ending a view ray.
    pub const SOLID_LIGHT: u64 = 0x736f_6c69;
    /// A shadow ray's march through the textures draws from `hash3(shadow key, 0, ..)`,
    /// indexed by instance and segment, not from the shadow key itself: a tree drawn from its
    /// model lights with the view ray's own key (the mesh method's stream), and a march indexed
    /// from that key drew the view ray's own sequences' shifts (instance 0, segment 114 is
    /// `SEGMENT_JITTER`'s slot).
    pub const SHADOW_MARCH: u64 = 0x6d61_7263;
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

/// The fractional part of the golden ratio, (sqrt 5 - 1) / 2: [`along`]'s step for a ray's
/// sample positions. Of all steps, its multiples spread most evenly over [0, 1) (the three-gap
/// theorem: the first n leave gaps below 2 / n).
pub const GOLDEN: f64 = 0.618_033_988_749_894_9;
/// sqrt 2 - 1: [`along`]'s step for a second purpose along the same ray, so that its draws do
/// not move in lockstep with the golden ones.
pub const SILVER: f64 = 0.414_213_562_373_095_1;
/// The R2 sequence's steps (Roberts 2018): 1 / g and 1 / g^2 for g the plastic number
/// (g^3 = g + 1), the golden ratio's generalisation to two dimensions; [`along2`]'s, which
/// fill the unit square as evenly as the golden ratio fills [0, 1).
pub const R2: [f64; 2] = [0.754_877_666_246_692_8, 0.569_840_290_998_053_3];

/// Draw `index` of a randomly shifted Kronecker sequence: frac(shift + index x `step`), the
/// shift uniform from `key`. Each draw on its own is uniform (the shift is), so an estimate
/// made from one draw alone keeps its expectation; successive draws along one key cover
/// [0, 1) evenly rather than at random (a ray's segments, sampled with them, are stratified
/// across the ray the way a single segment's jitter is within it). Where one draw's estimate
/// is weighted by what earlier draws of the same key found (a sample by the transmittance
/// the ray's earlier samples leave), the mean moves by their correlation: for a march, a
/// little nearer the exact exp(-integral), its samples' optical depths varying less.
pub fn along(key: u64, index: u64, step: f64) -> f64 {
    // frac of a number >= 0 (below 2^64, where every f64 is whole, the cast is exact): the
    // cast is one instruction, `f64::fract` a call into libm on baseline x86-64 (a ray's
    // segments take three draws each).
    debug_assert!(step >= 0.0, "a step of {step}");
    let x = index as f64 * step;
    let x = unit(key) + (x - (x as u64) as f64);
    if x >= 1.0 { x - 1.0 } else { x }
}

/// [`along`] in two dimensions, the R2 sequence with two shifts drawn from `key`.
pub fn along2(key: u64, index: u64) -> [f64; 2] {
    [along(key, index, R2[0]), along(mix64(key), index, R2[1])]
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

    /// A sequence's draws are uniform one by one over keys (each draw of a ray keeps its
    /// expectation), and along one key they fill the interval and the square evenly: the
    /// first n golden (or silver) draws leave no gap over 2.1 / n (1.88 / n and 2.05 / n at
    /// worst up to 200), where n random draws leave gaps of about ln n / n; no 4 x 4 cell of
    /// the square holds more than two of 16 R2 draws.
    #[test]
    fn sequences_are_uniform_over_keys_and_even_along_one() {
        let keys = 40_000u64;
        for index in [0u64, 1, 7, 1000] {
            let mut bins = [[0u32; 4]; 3];
            for k in 0..keys {
                let key = mix64(k);
                let draws = [
                    along(key, index, GOLDEN),
                    along(key, index, SILVER),
                    along2(key, index)[1],
                ];
                for (b, x) in bins.iter_mut().zip(draws) {
                    assert!((0.0..1.0).contains(&x));
                    b[(x * 4.0) as usize] += 1;
                }
            }
            for b in bins.iter().flatten() {
                assert!(
                    (f64::from(*b) - keys as f64 / 4.0).abs() < 400.0,
                    "{bins:?}"
                );
            }
        }
        for key in (0..50u64).map(mix64) {
            for step in [GOLDEN, SILVER] {
                for n in [2usize, 5, 16, 100, 199] {
                    let mut x: Vec<f64> = (0..n as u64).map(|i| along(key, i, step)).collect();
                    x.sort_by(f64::total_cmp);
                    // The gap across 0 too: the sequence lives on a circle.
                    let widest = x
                        .windows(2)
                        .map(|w| w[1] - w[0])
                        .fold(x[0] + 1.0 - x[n - 1], f64::max);
                    assert!(
                        widest < 2.1 / n as f64,
                        "step {step}, {n} draws: gap {widest}"
                    );
                }
            }
            let mut cells = [0u32; 16];
            for i in 0..16 {
                let [u, v] = along2(key, i);
                cells[(u * 4.0) as usize * 4 + (v * 4.0) as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c <= 2), "key {key}: {cells:?}");
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
            SHADOW_MARCH,
        ];
        for (i, a) in all.iter().enumerate() {
            assert!(!all[i + 1..].contains(a), "{a:#x} twice");
        }
    }
}
