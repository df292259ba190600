//! Reader for Gmsh MSH 4.1 ASCII files: Quad4 (type 3) and Hex8 (type 5) cells, physical groups
//! as named node and face sets.
//!
//! Supported sections: `$MeshFormat`, `$PhysicalNames`, `$Entities`, `$Nodes`, `$Elements`;
//! other sections are skipped. The mesh dimension is the highest dimension of a quad (2) or
//! hex (3) element block; elements of that dimension become cells, lower-dimensional elements
//! (points type 15, lines type 1, quads type 3 in 3D) only feed the sets.
//!
//! Sets: every physical group becomes a node set holding the nodes of all its elements (named
//! after `$PhysicalNames`, or `physical_{dim}_{tag}` without a name; groups of different
//! dimension with the same name are united). A physical group of dimension `dim - 1` also
//! becomes a face set: each of its line / quad elements is matched to the cell face with the
//! same nodes (an interior face goes to the first cell that has it); the face set keeps the
//! element order of the file, so it is ordered along the surface only if the file is.
//! Cells with negative Jacobian at the centre (e.g. a surface meshed with normal -z) are
//! renumbered to positive orientation (quad: nodes 1 and 3 swapped; hex: 1<->3 and 5<->7).
use super::{CellKind, Mesh, MeshError};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

/// Reads a Gmsh MSH 4.1 ASCII file.
pub fn read_gmsh(path: &Path) -> Result<Mesh, MeshError> {
    let text = std::fs::read_to_string(path).map_err(|source| MeshError::Io {
        path: path.display().to_string(),
        source,
    })?;
    parse_gmsh(&text, &path.display().to_string())
}

/// One whitespace-separated token and its 1-based line number.
type Token<'a> = (usize, &'a str);

/// Token cursor over one section, producing errors with file and line.
struct Cursor<'a> {
    path: &'a str,
    tokens: Vec<Token<'a>>,
    pos: usize,
    /// line of the section header, for errors at the end of the section
    end_line: usize,
}

impl<'a> Cursor<'a> {
    fn err(&self, line: usize, msg: impl Into<String>) -> MeshError {
        MeshError::Gmsh {
            path: self.path.to_string(),
            line,
            msg: msg.into(),
        }
    }

    fn next(&mut self, what: &str) -> Result<Token<'a>, MeshError> {
        let t = self.tokens.get(self.pos).copied().ok_or_else(|| {
            self.err(
                self.end_line,
                format!("section ends early, expected {what}"),
            )
        })?;
        self.pos += 1;
        Ok(t)
    }

    fn int(&mut self, what: &str) -> Result<(usize, i64), MeshError> {
        let (line, s) = self.next(what)?;
        s.parse::<i64>()
            .map(|v| (line, v))
            .map_err(|_| self.err(line, format!("expected integer {what}, found '{s}'")))
    }

    fn count(&mut self, what: &str) -> Result<usize, MeshError> {
        let (line, v) = self.int(what)?;
        usize::try_from(v)
            .map_err(|_| self.err(line, format!("{what} must be non-negative, found {v}")))
    }

    fn float(&mut self, what: &str) -> Result<f64, MeshError> {
        let (line, s) = self.next(what)?;
        s.parse::<f64>()
            .map_err(|_| self.err(line, format!("expected number {what}, found '{s}'")))
    }

    fn skip(&mut self, n: usize, what: &str) -> Result<(), MeshError> {
        for _ in 0..n {
            self.next(what)?;
        }
        Ok(())
    }
}

/// A section: name (without `$`), header line and the body lines with their numbers.
struct Section<'a> {
    name: &'a str,
    line: usize,
    body: Vec<Token<'a>>,
    lines: Vec<(usize, &'a str)>,
}

fn split_sections<'a>(text: &'a str, path: &str) -> Result<Vec<Section<'a>>, MeshError> {
    let err = |line, msg: String| MeshError::Gmsh {
        path: path.to_string(),
        line,
        msg,
    };
    let mut sections = Vec::new();
    let mut current: Option<Section<'a>> = None;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if let Some(name) = line.strip_prefix('$') {
            match current.take() {
                None => {
                    if name.starts_with("End") {
                        return Err(err(
                            line_no,
                            format!("'${name}' without an opening section"),
                        ));
                    }
                    current = Some(Section {
                        name,
                        line: line_no,
                        body: Vec::new(),
                        lines: Vec::new(),
                    });
                }
                Some(sec) => {
                    if name.strip_prefix("End") != Some(sec.name) {
                        return Err(err(
                            line_no,
                            format!("expected '$End{}', found '${name}'", sec.name),
                        ));
                    }
                    sections.push(sec);
                }
            }
        } else if let Some(sec) = current.as_mut() {
            if !line.is_empty() {
                sec.body
                    .extend(line.split_whitespace().map(|t| (line_no, t)));
                sec.lines.push((line_no, line));
            }
        } else if !line.is_empty() {
            return Err(err(line_no, format!("text outside of a section: '{line}'")));
        }
    }
    if let Some(sec) = current {
        return Err(err(
            sec.line,
            format!("section '${}' is never closed", sec.name),
        ));
    }
    Ok(sections)
}

/// Number of nodes of a supported Gmsh element type.
fn nodes_per_element(ty: i64) -> Option<usize> {
    match ty {
        1 => Some(2),  // 2-node line
        3 => Some(4),  // 4-node quadrangle
        5 => Some(8),  // 8-node hexahedron
        15 => Some(1), // point
        _ => None,
    }
}

/// An element block of `$Elements` with its elements' node numbers (already mapped to mesh
/// node indices) and source lines.
struct Block {
    dim: usize,
    entity: i64,
    ty: i64,
    /// [n_elems][nodes_per_element]
    nodes: Vec<u32>,
    lines: Vec<usize>,
}

/// Parses MSH 4.1 ASCII text; `path` only labels errors.
pub fn parse_gmsh<'a>(text: &'a str, path: &'a str) -> Result<Mesh, MeshError> {
    let err = |line, msg: String| MeshError::Gmsh {
        path: path.to_string(),
        line,
        msg,
    };
    let sections = split_sections(text, path)?;
    let cursor = |s: &Section<'a>| -> Cursor<'a> {
        Cursor {
            path,
            tokens: s.body.clone(),
            pos: 0,
            end_line: s.line,
        }
    };

    let format = sections
        .iter()
        .find(|s| s.name == "MeshFormat")
        .ok_or_else(|| err(1, "no $MeshFormat section".into()))?;
    {
        let mut c = cursor(format);
        let (line, version) = c.next("version")?;
        if !version.starts_with("4.1") {
            return Err(err(
                line,
                format!("MSH version {version} is not supported (need 4.1)"),
            ));
        }
        let (line, file_type) = c.int("file-type")?;
        if file_type != 0 {
            return Err(err(
                line,
                "binary MSH files are not supported (need ASCII, file-type 0)".into(),
            ));
        }
    }

    // physical (dim, tag) -> name
    let mut physical_names: HashMap<(usize, i64), String> = HashMap::new();
    if let Some(sec) = sections.iter().find(|s| s.name == "PhysicalNames") {
        let mut lines = sec.lines.iter();
        let (line, first) = lines
            .next()
            .ok_or_else(|| err(sec.line, "empty $PhysicalNames".into()))?;
        let n: usize = first.parse().map_err(|_| {
            err(
                *line,
                format!("expected number of physical names, found '{first}'"),
            )
        })?;
        for _ in 0..n {
            let (line, text) = lines
                .next()
                .ok_or_else(|| err(sec.line, "$PhysicalNames ends early".into()))?;
            let mut parts = text.splitn(3, char::is_whitespace);
            let dim = parts.next().and_then(|s| s.parse::<usize>().ok());
            let tag = parts.next().and_then(|s| s.parse::<i64>().ok());
            let name = parts.next().map(|s| s.trim().trim_matches('"').to_string());
            match (dim, tag, name) {
                (Some(d), Some(t), Some(name)) if !name.is_empty() => {
                    physical_names.insert((d, t), name);
                }
                _ => {
                    return Err(err(
                        *line,
                        format!("expected 'dim tag \"name\"', found '{text}'"),
                    ));
                }
            }
        }
    }

    // entity (dim, tag) -> physical tags
    let mut entity_physicals: HashMap<(usize, i64), Vec<i64>> = HashMap::new();
    if let Some(sec) = sections.iter().find(|s| s.name == "Entities") {
        let mut c = cursor(sec);
        let mut counts = [0usize; 4];
        for (d, n) in counts.iter_mut().enumerate() {
            *n = c.count(&format!("number of entities of dimension {d}"))?;
        }
        for (d, &n) in counts.iter().enumerate() {
            for _ in 0..n {
                let (_, tag) = c.int("entity tag")?;
                // a point has x y z, higher entities a bounding box
                c.skip(if d == 0 { 3 } else { 6 }, "entity coordinates")?;
                let n_phys = c.count("number of physical tags")?;
                let mut tags = Vec::with_capacity(n_phys);
                for _ in 0..n_phys {
                    tags.push(c.int("physical tag")?.1);
                }
                entity_physicals.insert((d, tag), tags);
                if d > 0 {
                    let n_bound = c.count("number of bounding entities")?;
                    c.skip(n_bound, "bounding entity tag")?;
                }
            }
        }
    }

    // nodes: tag -> index in order of appearance, coordinates [n][3]
    let nodes_sec = sections
        .iter()
        .find(|s| s.name == "Nodes")
        .ok_or_else(|| err(1, "no $Nodes section".into()))?;
    let mut node_index: HashMap<i64, u32> = HashMap::new();
    let mut xyz: Vec<f64> = Vec::new();
    let mut xyz_lines: Vec<usize> = Vec::new();
    {
        let mut c = cursor(nodes_sec);
        let n_blocks = c.count("number of node blocks")?;
        let _n_nodes = c.count("number of nodes")?;
        c.skip(2, "min/max node tag")?;
        for _ in 0..n_blocks {
            let entity_dim = c.count("entity dimension")?;
            c.int("entity tag")?;
            let (line, parametric) = c.int("parametric flag")?;
            if parametric != 0 && parametric != 1 {
                return Err(err(
                    line,
                    format!("parametric flag must be 0 or 1, found {parametric}"),
                ));
            }
            let n = c.count("number of nodes in block")?;
            let mut tags = Vec::with_capacity(n);
            for _ in 0..n {
                let (line, tag) = c.int("node tag")?;
                let index = node_index.len() as u32;
                if node_index.insert(tag, index).is_some() {
                    return Err(err(line, format!("node tag {tag} defined twice")));
                }
                tags.push(tag);
            }
            for _ in 0..n {
                let line = c.tokens.get(c.pos).map(|t| t.0).unwrap_or(c.end_line);
                for k in 0..3 {
                    xyz.push(c.float(&format!("node coordinate {k}"))?);
                }
                if parametric == 1 {
                    c.skip(entity_dim.min(3), "parametric coordinate")?;
                }
                xyz_lines.push(line);
            }
        }
    }

    // element blocks
    let elems_sec = sections
        .iter()
        .find(|s| s.name == "Elements")
        .ok_or_else(|| err(1, "no $Elements section".into()))?;
    let mut blocks: Vec<Block> = Vec::new();
    {
        let mut c = cursor(elems_sec);
        let n_blocks = c.count("number of element blocks")?;
        c.count("number of elements")?;
        c.skip(2, "min/max element tag")?;
        for _ in 0..n_blocks {
            let dim = c.count("entity dimension")?;
            let (_, entity) = c.int("entity tag")?;
            let (line, ty) = c.int("element type")?;
            let npe = nodes_per_element(ty).ok_or_else(|| {
                err(
                    line,
                    format!(
                        "element type {ty} is not supported (only 1 line, 3 quad, 5 hex, 15 point)"
                    ),
                )
            })?;
            let n = c.count("number of elements in block")?;
            let mut block = Block {
                dim,
                entity,
                ty,
                nodes: Vec::with_capacity(n * npe),
                lines: Vec::with_capacity(n),
            };
            for _ in 0..n {
                let (line, _tag) = c.int("element tag")?;
                for _ in 0..npe {
                    let (line, tag) = c.int("element node tag")?;
                    let idx = node_index.get(&tag).ok_or_else(|| {
                        err(line, format!("element refers to undefined node tag {tag}"))
                    })?;
                    block.nodes.push(*idx);
                }
                block.lines.push(line);
            }
            blocks.push(block);
        }
    }

    let dim = blocks
        .iter()
        .filter_map(|b| match b.ty {
            3 if b.dim == 2 => Some(2),
            5 => Some(3),
            _ => None,
        })
        .max()
        .ok_or_else(|| {
            err(
                elems_sec.line,
                "no quadrangle (type 3) or hexahedron (type 5) elements".into(),
            )
        })?;

    let mut mesh = Mesh::new(dim);
    for (n, p) in xyz.chunks(3).enumerate() {
        if dim == 2 && p[2] != 0.0 {
            return Err(err(
                xyz_lines[n],
                format!(
                    "2D mesh node has z = {} (must lie in the plane z = 0)",
                    p[2]
                ),
            ));
        }
        mesh.push_node(&p[..dim]);
    }
    let cell_kind = if dim == 2 {
        CellKind::Quad4
    } else {
        CellKind::Hex8
    };
    let cell_type = if dim == 2 { 3 } else { 5 };
    for b in blocks.iter().filter(|b| b.dim == dim) {
        if b.ty != cell_type {
            return Err(err(
                b.lines.first().copied().unwrap_or(elems_sec.line),
                format!(
                    "element type {} in a {dim}D block of a mesh of {cell_kind:?} cells",
                    b.ty
                ),
            ));
        }
        for nodes in b.nodes.chunks(cell_kind.n_nodes()) {
            let c = mesh.push_cell(cell_kind, nodes) as usize;
            let x: Vec<f64> = nodes.iter().flat_map(|&n| mesh.node(n).to_vec()).collect();
            if cell_kind.jacobian_det(&x, &[0.0; 3][..dim]) < 0.0 {
                let s = mesh.cell_offsets[c];
                mesh.cell_nodes.swap(s + 1, s + 3);
                if dim == 3 {
                    mesh.cell_nodes.swap(s + 5, s + 7);
                }
            }
        }
    }

    // sorted face node keys -> (cell, face)
    let mut face_of: HashMap<Vec<u32>, (u32, u8)> = HashMap::new();
    for c in 0..mesh.n_cells() {
        for f in 0..cell_kind.n_faces() as u8 {
            let mut key = mesh.face_nodes(c, f)?;
            key.sort_unstable();
            face_of.entry(key).or_insert((c as u32, f));
        }
    }

    let mut node_sets: BTreeMap<String, Vec<u32>> = BTreeMap::new();
    let mut face_sets: BTreeMap<String, Vec<(u32, u8)>> = BTreeMap::new();
    for b in &blocks {
        let Some(phys) = entity_physicals.get(&(b.dim, b.entity)) else {
            continue;
        };
        let npe = nodes_per_element(b.ty).unwrap_or(1);
        for &p in phys {
            let tag = p.abs();
            let name = physical_names
                .get(&(b.dim, tag))
                .cloned()
                .unwrap_or_else(|| format!("physical_{}_{tag}", b.dim));
            node_sets
                .entry(name.clone())
                .or_default()
                .extend_from_slice(&b.nodes);
            let is_face = b.dim + 1 == dim && ((dim == 2 && b.ty == 1) || (dim == 3 && b.ty == 3));
            if is_face {
                let faces = face_sets.entry(name.clone()).or_default();
                for (e, nodes) in b.nodes.chunks(npe).enumerate() {
                    let mut key = nodes.to_vec();
                    key.sort_unstable();
                    let face = face_of.get(&key).ok_or_else(|| {
                        err(
                            b.lines[e],
                            format!(
                                "boundary element of physical group '{name}' matches no cell face"
                            ),
                        )
                    })?;
                    faces.push(*face);
                }
            }
        }
    }
    for (name, nodes) in node_sets {
        mesh.insert_node_set(&name, nodes);
    }
    mesh.face_sets = face_sets;
    mesh.validate()?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 2 x 1 quads on [0, 2] x [0, 1]; physical lines "bottom" (two lines, left to right),
    /// "right"; physical surface "body"; points of the right edge numbered out of order.
    const QUADS_2X1: &str = r#"$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
3
1 1 "bottom"
1 2 "right"
2 3 "body"
$EndPhysicalNames
$Entities
0 2 1 0
1 0 0 0 2 0 0 1 1 0
2 2 0 0 2 1 0 1 2 0
1 0 0 0 2 1 0 1 3 0
$EndEntities
$Nodes
1 6 1 6
2 1 0 6
1
2
3
4
5
6
0 0 0
1 0 0
2 0 0
2 1 0
1 1 0
0 1 0
$EndNodes
$Elements
3 5 1 5
1 1 1 2
1 1 2
2 2 3
1 2 1 1
3 3 4
2 1 3 2
4 1 2 5 6
5 2 3 4 5
$EndElements
"#;

    /// One unit hex, with its bottom face as physical surface "base" (listed clockwise seen
    /// from below, i.e. any orientation) and volume "cube".
    const ONE_HEX: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
$PhysicalNames\n2\n2 1 \"base\"\n3 2 \"cube\"\n$EndPhysicalNames\n\
$Entities\n0 0 1 1\n1 0 0 0 1 1 0 1 1 0\n1 0 0 0 1 1 1 1 2 1 1\n$EndEntities\n\
$Nodes\n1 8 1 8\n3 1 0 8\n1\n2\n3\n4\n5\n6\n7\n8\n\
0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n$EndNodes\n\
$Elements\n2 2 1 2\n2 1 3 1\n1 1 2 3 4\n3 1 5 1\n2 1 2 3 4 5 6 7 8\n$EndElements\n";

    fn write_temp(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("scratch_mesh_gmsh_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn reads_2x1_quad_mesh_with_sets() {
        let path = write_temp("quads.msh", QUADS_2X1);
        let m = read_gmsh(&path).unwrap();
        assert_eq!(m.dim, 2);
        assert_eq!(m.n_nodes(), 6);
        assert_eq!(m.n_cells(), 2);
        assert!((m.measure() - 2.0).abs() < 1e-14);
        assert_eq!(m.cell(0), &[0, 1, 4, 5]);
        assert_eq!(m.node_sets["bottom"], vec![0, 1, 2]);
        assert_eq!(m.node_sets["right"], vec![2, 3]);
        assert_eq!(m.node_sets["body"], vec![0, 1, 2, 3, 4, 5]);
        // bottom lines in file order: cell 0 face 0, then cell 1 face 0
        assert_eq!(m.face_sets["bottom"], vec![(0, 0), (1, 0)]);
        assert_eq!(m.face_sets["right"], vec![(1, 1)]);
        assert!(!m.face_sets.contains_key("body"));
    }

    #[test]
    fn reads_one_hex_with_base_face_set() {
        let path = write_temp("hex.msh", ONE_HEX);
        let m = read_gmsh(&path).unwrap();
        assert_eq!(m.dim, 3);
        assert_eq!(m.n_cells(), 1);
        assert!((m.measure() - 1.0).abs() < 1e-14);
        assert_eq!(m.face_sets["base"], vec![(0, 0)]);
        assert_eq!(m.node_sets["base"], vec![0, 1, 2, 3]);
        assert_eq!(m.node_sets["cube"].len(), 8);
    }

    #[test]
    fn generated_rectangle_round_trips_through_msh() {
        let r = crate::mesh::rectangle::rectangle([0.0, 0.0], [3.0, 1.0], [3, 2]).unwrap();
        let text = write_msh_2d(&r, "top");
        let m = parse_gmsh(&text, "roundtrip.msh").unwrap();
        assert_eq!(m.coords, r.coords);
        assert_eq!(m.cell_nodes, r.cell_nodes);
        assert_eq!(m.face_sets["top"], r.face_sets["top"]);
        assert_eq!(m.node_sets["top"], r.node_sets["top"]);
    }

    /// Minimal MSH 4.1 writer for the round trip test: one surface entity, one curve entity
    /// carrying face set `set` as physical line 1.
    fn write_msh_2d(m: &Mesh, set: &str) -> String {
        let mut s = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
        s += &format!("$PhysicalNames\n1\n1 1 \"{set}\"\n$EndPhysicalNames\n");
        s += "$Entities\n0 1 1 0\n1 0 0 0 1 1 0 1 1 0\n1 0 0 0 1 1 0 0 0\n$EndEntities\n";
        let n = m.n_nodes();
        s += &format!("$Nodes\n1 {n} 1 {n}\n2 1 0 {n}\n");
        for i in 0..n {
            s += &format!("{}\n", i + 1);
        }
        for i in 0..n as u32 {
            s += &format!("{} {} 0\n", m.node(i)[0], m.node(i)[1]);
        }
        s += "$EndNodes\n";
        let faces = &m.face_sets[set];
        let total = m.n_cells() + faces.len();
        s += &format!("$Elements\n2 {total} 1 {total}\n1 1 1 {}\n", faces.len());
        for (e, &(c, f)) in faces.iter().enumerate() {
            let fn_ = m.face_nodes(c as usize, f).unwrap();
            s += &format!("{} {} {}\n", e + 1, fn_[0] + 1, fn_[1] + 1);
        }
        s += &format!("2 1 3 {}\n", m.n_cells());
        for c in 0..m.n_cells() {
            let ns: Vec<String> = m.cell(c).iter().map(|&a| (a + 1).to_string()).collect();
            s += &format!("{} {}\n", faces.len() + c + 1, ns.join(" "));
        }
        s + "$EndElements\n"
    }

    #[test]
    fn clockwise_quads_are_reoriented() {
        let text = QUADS_2X1.replace("4 1 2 5 6", "4 1 6 5 2");
        let m = parse_gmsh(&text, "cw.msh").unwrap();
        assert!(m.cell_measure(0) > 0.0);
        assert_eq!(m.face_sets["bottom"].len(), 2);
    }

    #[test]
    fn errors_name_file_and_line() {
        let line_of = |text: &str, l: &str| text.lines().position(|x| x == l).unwrap() + 1;
        let text = QUADS_2X1.replace("5 2 3 4 5", "5 2 3 4 99");
        match parse_gmsh(&text, "bad.msh") {
            Err(MeshError::Gmsh { path, line, msg }) => {
                assert_eq!(path, "bad.msh");
                assert_eq!(line, line_of(&text, "5 2 3 4 99"));
                assert!(msg.contains("99"), "{msg}");
            }
            other => panic!("expected Gmsh error, got {other:?}"),
        }
        let text = QUADS_2X1.replace("2 1 3 2", "2 1 2 2");
        let e = parse_gmsh(&text, "tri.msh").unwrap_err();
        assert!(
            matches!(e, MeshError::Gmsh { line, .. } if line == line_of(&text, "2 1 2 2")),
            "{e}"
        );
        assert!(e.to_string().contains("type 2"), "{e}");
        let e = parse_gmsh(&QUADS_2X1.replace("4.1 0 8", "2.2 0 8"), "old.msh").unwrap_err();
        assert!(matches!(e, MeshError::Gmsh { line: 2, .. }), "{e}");
        let e = parse_gmsh(&QUADS_2X1.replace("$EndNodes\n", ""), "open.msh").unwrap_err();
        assert!(e.to_string().starts_with("open.msh:"), "{e}");
    }

    #[test]
    fn missing_file_error_names_the_path() {
        let p = std::path::Path::new("/nonexistent/dir/mesh.msh");
        let e = read_gmsh(p).unwrap_err();
        assert!(matches!(e, MeshError::Io { .. }));
        assert!(e.to_string().contains("/nonexistent/dir/mesh.msh"));
    }
}
