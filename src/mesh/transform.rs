//! Rigid helpers: translate, scale and merge meshes (bodies stay disconnected).
use super::{Mesh, MeshError};

/// Shifts every node by `offset` ([dim]).
pub fn translate(mesh: &mut Mesh, offset: &[f64]) -> Result<(), MeshError> {
    if offset.len() != mesh.dim {
        return Err(MeshError::InvalidParameter {
            name: "offset",
            value: format!("{offset:?}"),
            reason: "length must equal the mesh dimension",
        });
    }
    for x in mesh.coords.chunks_mut(mesh.dim) {
        x.iter_mut().zip(offset).for_each(|(a, b)| *a += b);
    }
    mesh.exact_surfaces
        .values_mut()
        .for_each(|p| p.translate(offset));
    Ok(())
}

/// Scales every coordinate by `factor` (> 0, so that orientation is kept) about the origin.
pub fn scale(mesh: &mut Mesh, factor: f64) -> Result<(), MeshError> {
    if !(factor > 0.0 && factor.is_finite()) {
        return Err(MeshError::InvalidParameter {
            name: "factor",
            value: factor.to_string(),
            reason: "must be positive and finite",
        });
    }
    mesh.coords.iter_mut().for_each(|x| *x *= factor);
    mesh.exact_surfaces
        .values_mut()
        .for_each(|p| p.scale(factor));
    Ok(())
}

/// Where the nodes and cells of one part ended up in a merged mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PartRange {
    /// First node number of the part.
    pub first_node: u32,
    pub n_nodes: usize,
    /// First cell number of the part.
    pub first_cell: u32,
    pub n_cells: usize,
}

/// Concatenates `parts` (prefix, mesh) without joining nodes: each part stays a separate body.
/// Set `name` of a part becomes `"{prefix}/{name}"` (or `name` if the prefix is empty);
/// a clash of names or of dimensions is an error.
pub fn merge(parts: &[(&str, &Mesh)]) -> Result<(Mesh, Vec<PartRange>), MeshError> {
    let dim = parts
        .first()
        .map(|p| p.1.dim)
        .ok_or_else(|| MeshError::Merge("no parts given".into()))?;
    let mut out = Mesh::new(dim);
    let mut ranges = Vec::with_capacity(parts.len());
    for &(prefix, part) in parts {
        if part.dim != dim {
            return Err(MeshError::Merge(format!(
                "part '{prefix}' has dimension {}, expected {dim}",
                part.dim
            )));
        }
        let n0 = out.n_nodes() as u32;
        let c0 = out.n_cells() as u32;
        out.coords.extend_from_slice(&part.coords);
        for c in 0..part.n_cells() {
            let nodes: Vec<u32> = part.cell(c).iter().map(|&n| n + n0).collect();
            out.push_cell(part.cell_kind[c], &nodes);
        }
        let rename = |name: &str| {
            if prefix.is_empty() {
                name.to_string()
            } else {
                format!("{prefix}/{name}")
            }
        };
        for (name, nodes) in &part.node_sets {
            let key = rename(name);
            if out.node_sets.contains_key(&key) {
                return Err(MeshError::Merge(format!("node set '{key}' defined twice")));
            }
            out.node_sets
                .insert(key, nodes.iter().map(|&n| n + n0).collect());
        }
        for (name, faces) in &part.face_sets {
            let key = rename(name);
            if out.face_sets.contains_key(&key) {
                return Err(MeshError::Merge(format!("face set '{key}' defined twice")));
            }
            out.face_sets
                .insert(key, faces.iter().map(|&(c, f)| (c + c0, f)).collect());
        }
        for (name, patch) in &part.exact_surfaces {
            let mut p = patch.clone();
            p.nodes.iter_mut().for_each(|n| *n += n0);
            out.exact_surfaces.insert(rename(name), p);
        }
        out.collapsed_nodes
            .extend(part.collapsed_nodes.iter().map(|&n| n + n0));
        out.node_tags.extend_from_slice(&part.node_tags);
        ranges.push(PartRange {
            first_node: n0,
            n_nodes: part.n_nodes(),
            first_cell: c0,
            n_cells: part.n_cells(),
        });
    }
    // tags name nodes only when every part has them
    if out.node_tags.len() != out.n_nodes() {
        out.node_tags.clear();
    }
    Ok((out, ranges))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::half_disk::half_disk;
    use crate::mesh::rectangle::{rectangle_oriented, Side};

    #[test]
    fn merged_ironing_bodies_keep_sets_areas_and_validity() {
        let block = rectangle_oriented([0.0, 0.0], [10.0, 2.0], [40, 8], Side::Top).unwrap();
        let mut cyl = half_disk([0.0, 0.0], 1.0, 16, 3).unwrap();
        translate(&mut cyl, &[5.0, 3.0]).unwrap();
        let (m, ranges) = merge(&[("block", &block), ("cylinder", &cyl)]).unwrap();
        m.validate().unwrap();
        assert!((m.measure() - block.measure() - cyl.measure()).abs() < 1e-12);
        assert_eq!(ranges[1].first_node as usize, block.n_nodes());
        assert_eq!(ranges[1].first_cell as usize, block.n_cells());
        let top = m.node_set_from_faces("cylinder/top").unwrap();
        assert!(top.iter().all(|&n| (m.node(n)[1] - 3.0).abs() < 1e-12));
        assert_eq!(m.face_sets["block/top"].len(), 40);
        assert!(matches!(
            merge(&[("a", &block), ("a", &block)]),
            Err(MeshError::Merge(_))
        ));
    }

    #[test]
    fn scale_keeps_orientation_and_scales_area() {
        let mut m = half_disk([0.0, 0.0], 1.0, 8, 2).unwrap();
        let a = m.measure();
        scale(&mut m, 3.0).unwrap();
        m.validate().unwrap();
        assert!((m.measure() - 9.0 * a).abs() < 1e-12);
        assert!(scale(&mut m, -1.0).is_err());
    }
}
