//! Per-triangle properties the scan needs: is it foliage, and does it bound a closed solid.

use std::collections::HashMap;

use regex::Regex;

use crate::import::Mesh;

/// Foliage triangles: their material's name matches `foliage` or their material is alpha-tested
/// (leaf cards). Everything else is wood.
pub fn foliage_triangles(mesh: &Mesh, foliage: &Regex) -> Vec<bool> {
    let is_foliage: Vec<bool> = mesh
        .materials
        .iter()
        .map(|m| m.is_alpha_tested() || foliage.is_match(&m.name))
        .collect();
    mesh.triangles
        .iter()
        .map(|t| is_foliage[t.material as usize])
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
    (0..n as u32)
        .map(|t| component_closed[find(&mut parent, t) as usize])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::{Material, Triangle};
    use glam::{Vec2, Vec3, Vec4};

    fn mesh(positions: Vec<Vec3>, tris: &[[u32; 3]]) -> Mesh {
        let n = positions.len();
        Mesh {
            positions,
            uvs: vec![Vec2::ZERO; n],
            colors: vec![Vec4::ONE; n],
            triangles: tris
                .iter()
                .map(|&vertices| Triangle {
                    vertices,
                    material: 0,
                })
                .collect(),
            materials: vec![Material::default()],
            textures: vec![],
        }
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
