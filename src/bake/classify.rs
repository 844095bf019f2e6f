//! Per-triangle properties the scan needs: is it foliage, and does it bound a closed solid.

use std::collections::HashMap;

use regex::Regex;

use crate::import::{AlphaMode, Mesh};
use crate::volume::{MaterialPart, PartReason};

/// Share of a material's surface its alpha must remove for the material to count as leaf
/// cards. Exporters mark whole packs `MASK`, bark included, with fully opaque textures; a
/// mask that removes nothing says nothing about what the surface is.
pub const MIN_CUT: f32 = 0.01;

/// Barycentric sample points per triangle side when measuring what a mask removes: n^2
/// points, the centroids of the sub-triangles of a regular n-subdivision.
const CUT_SAMPLES_PER_SIDE: usize = 4;

/// How each of `mesh`'s materials divides between wood and foliage, in the order of
/// `mesh.materials`. A material is wood when its name matches `wood`; else foliage when its
/// name matches `foliage`, or when its alpha (`MASK` or `BLEND`) actually removes at least
/// [`MIN_CUT`] of its surface (leaf cards); else wood.
pub fn material_parts(mesh: &Mesh, foliage: &Regex, wood: Option<&Regex>) -> Vec<MaterialPart> {
    let cut = cut_fractions(mesh);
    let mut triangles = vec![0u64; mesh.materials.len()];
    for t in &mesh.triangles {
        triangles[t.material as usize] += 1;
    }
    mesh.materials
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let reason = if wood.is_some_and(|w| w.is_match(&m.name)) {
                PartReason::WoodPattern
            } else if foliage.is_match(&m.name) {
                PartReason::FoliagePattern
            } else if cut[i] >= MIN_CUT {
                PartReason::AlphaCuts
            } else {
                PartReason::Solid
            };
            MaterialPart {
                name: m.name.clone(),
                foliage: matches!(reason, PartReason::FoliagePattern | PartReason::AlphaCuts),
                reason,
                cut: cut[i],
                triangles: triangles[i],
            }
        })
        .collect()
}

/// Per material, the share of its triangles' area its alpha removes: for `MASK` the area
/// where alpha falls below the cutoff, for `BLEND` the mean of `1 - alpha`; 0 for opaque
/// materials. Measured at the same texture lookups the scan makes.
fn cut_fractions(mesh: &Mesh) -> Vec<f32> {
    let n = CUT_SAMPLES_PER_SIDE;
    let mut removed = vec![0.0f64; mesh.materials.len()];
    let mut area = vec![0.0f64; mesh.materials.len()];
    for t in &mesh.triangles {
        let material = &mesh.materials[t.material as usize];
        if matches!(material.alpha_mode, AlphaMode::Opaque) {
            continue;
        }
        let [a, b, c] = t.vertices.map(|v| mesh.positions[v as usize].as_dvec3());
        let weight = (b - a).cross(c - a).length().max(f64::MIN_POSITIVE);
        let mut gone = 0.0f64;
        let mut count = 0usize;
        for (u, v) in subdivision_centroids(n) {
            let alpha = mesh.base_color(t, [1.0 - u - v, u, v]).w;
            gone += match material.alpha_mode {
                AlphaMode::Mask { cutoff } => f64::from(u8::from(alpha < cutoff)),
                _ => f64::from(1.0 - alpha.clamp(0.0, 1.0)),
            };
            count += 1;
        }
        removed[t.material as usize] += weight * gone / count as f64;
        area[t.material as usize] += weight;
    }
    removed
        .iter()
        .zip(&area)
        .map(|(&r, &a)| if a > 0.0 { (r / a) as f32 } else { 0.0 })
        .collect()
}

/// Barycentric (u, v) of the centroids of the n^2 sub-triangles of a triangle cut into an
/// n-subdivision: an even spread over its area.
fn subdivision_centroids(n: usize) -> impl Iterator<Item = (f32, f32)> {
    let step = 1.0 / n as f32;
    (0..n).flat_map(move |i| {
        (0..n - i).flat_map(move |j| {
            let (u, v) = (i as f32 * step, j as f32 * step);
            // The upward sub-triangle at (i, j), and the downward one beside it if any.
            let up = (u + step / 3.0, v + step / 3.0);
            let down = (i + j + 1 < n).then_some((u + 2.0 * step / 3.0, v + 2.0 * step / 3.0));
            std::iter::once(up).chain(down)
        })
    })
}

/// Foliage triangles under `parts` (from [`material_parts`]).
pub fn foliage_triangles(mesh: &Mesh, parts: &[MaterialPart]) -> Vec<bool> {
    mesh.triangles
        .iter()
        .map(|t| parts[t.material as usize].foliage)
        .collect()
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        parent[i as usize] = parent[parent[i as usize] as usize];
        i = parent[i as usize];
    }
    i
}

/// Which triangles belong to a closed surface: a connected component (triangles joined by
/// shared edges, vertices welded by exact position) in which every edge is shared by an even
/// number of triangles. Only closed parts have an inside; leaf cards and other open sheets are
/// surfaces without volume.
pub fn closed_triangles(mesh: &Mesh) -> Vec<bool> {
    closed_components(mesh)
        .iter()
        .map(Option::is_some)
        .collect()
}

/// Per triangle, the closed component it belongs to (numbered from 0 in order of their first
/// triangle), or `None` for a triangle of an open one: the components of
/// [`closed_triangles`].
pub fn closed_components(mesh: &Mesh) -> Vec<Option<u32>> {
    let mut weld: HashMap<[u32; 3], u32> = HashMap::new();
    let welded: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let key = p.to_array().map(|c| (c + 0.0).to_bits()); // +0.0 folds -0.0 into 0.0
            let next = weld.len() as u32;
            *weld.entry(key).or_insert(next)
        })
        .collect();

    let n = mesh.triangles.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new(); // edge -> (uses, a triangle)
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let v = tri.vertices.map(|i| welded[i as usize]);
        for (a, b) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
            let key = (a.min(b), a.max(b));
            let entry = edges.entry(key).or_insert((0, t as u32));
            entry.0 += 1;
            let (ra, rb) = (find(&mut parent, entry.1), find(&mut parent, t as u32));
            if ra != rb {
                parent[ra.max(rb) as usize] = ra.min(rb);
            }
        }
    }
    let mut component_closed = vec![true; n];
    for (uses, t) in edges.values() {
        if uses % 2 == 1 {
            let root = find(&mut parent, *t);
            component_closed[root as usize] = false;
        }
    }
    let mut number: HashMap<u32, u32> = HashMap::new();
    (0..n as u32)
        .map(|t| {
            let root = find(&mut parent, t);
            component_closed[root as usize].then(|| {
                let next = number.len() as u32;
                *number.entry(root).or_insert(next)
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::Material;
    use glam::Vec3;

    fn mesh(positions: Vec<Vec3>, tris: &[[u32; 3]]) -> Mesh {
        Mesh::plain(positions, tris, Material::default())
    }

    #[test]
    fn a_tetrahedron_is_closed_and_a_quad_is_open() {
        let p = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            Vec3::new(5.0, 0.0, 0.0),
            Vec3::new(6.0, 0.0, 0.0),
            Vec3::new(6.0, 1.0, 0.0),
            Vec3::new(5.0, 1.0, 0.0),
        ];
        let m = mesh(
            p,
            &[
                [0, 2, 1],
                [0, 1, 3],
                [1, 2, 3],
                [0, 3, 2],
                [4, 5, 6],
                [4, 6, 7],
            ],
        );
        assert_eq!(
            closed_triangles(&m),
            vec![true, true, true, true, false, false]
        );
    }

    #[test]
    fn duplicated_vertices_are_welded() {
        // The same tetrahedron with every triangle owning its own vertices, as exporters write
        // flat-shaded meshes.
        let corners = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let tris = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        let p: Vec<Vec3> = tris.iter().flat_map(|t| t.map(|i| corners[i])).collect();
        let own: Vec<[u32; 3]> = (0..4).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        assert!(closed_triangles(&mesh(p, &own)).iter().all(|&c| c));
    }
}
