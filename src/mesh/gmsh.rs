//! Reader for Gmsh MSH 4.1 ASCII files: Quad4 (type 3) and Hex8 (type 5) cells, physical groups
//! as named node and face sets.
//!
//! Supported sections: `$MeshFormat`, `$PhysicalNames`, `$Entities`, `$Nodes`, `$Elements`;
//! other sections are skipped. An element block's entity has its elements' dimension (point 0,
//! line 1, quad 2, hex 3). The mesh dimension is the highest dimension of a quad (2) or hex (3)
//! block that holds elements, and a mesh without one is an error; elements of that dimension
//! become cells, lower-dimensional elements (points type 15, lines type 1, quads type 3 in 3D)
//! only feed the sets.
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

/// Reads a Gmsh MSH 4.1 ASCII file (warnings dropped: see [`read_gmsh_with_warnings`]).
pub fn read_gmsh(path: &Path) -> Result<Mesh, MeshError> {
    read_gmsh_with_warnings(path).map(|(m, _)| m)
}

/// How many node tags a warning about unused nodes lists.
const UNUSED_NODES_SHOWN: usize = 5;

/// Reads a Gmsh MSH 4.1 ASCII file; also returns warnings about what is legal but suspicious
/// (nodes in no element), each naming the file.
pub fn read_gmsh_with_warnings(path: &Path) -> Result<(Mesh, Vec<String>), MeshError> {
    let text = std::fs::read_to_string(path).map_err(|source| MeshError::Io {
        path: path.display().to_string(),
        source,
    })?;
    parse_gmsh_with_warnings(&text, &path.display().to_string())
}

/// Parses MSH 4.1 ASCII text; `path` only labels errors.
pub fn parse_gmsh(text: &str, path: &str) -> Result<Mesh, MeshError> {
    parse_gmsh_with_warnings(text, path).map(|(m, _)| m)
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

    /// Values left in the section.
    fn remaining(&self) -> usize {
        self.tokens.len() - self.pos
    }

    /// Reads a count of entries that each take at least `per_entry` more values, and checks that
    /// the rest of the section can hold them: a count is never trusted before it allocates.
    fn count_fitting(&mut self, what: &str, per_entry: usize) -> Result<(usize, usize), MeshError> {
        let (line, v) = self.int(what)?;
        let n = usize::try_from(v)
            .map_err(|_| self.err(line, format!("{what} must be non-negative, found {v}")))?;
        let left = self.remaining();
        if n.checked_mul(per_entry).is_none_or(|need| need > left) {
            return Err(self.err(
                line,
                format!(
                    "{what} = {n} disagrees with the file: the rest of the section holds {left} \
                     values, and each entry needs at least {per_entry}"
                ),
            ));
        }
        Ok((line, n))
    }

    /// Fails at the first value left over after the last block the header announced.
    fn expect_end(&self, section: &str, header: &str) -> Result<(), MeshError> {
        match self.tokens.get(self.pos) {
            None => Ok(()),
            Some(&(line, t)) => Err(self.err(
                line,
                format!(
                    "unexpected '{t}' after the last block of ${section}: the header {header}, \
                     and the data holds more"
                ),
            )),
        }
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
    element_shape(ty).map(|(npe, _, _)| npe)
}

/// Nodes, dimension and name of a supported Gmsh element type.
fn element_shape(ty: i64) -> Option<(usize, usize, &'static str)> {
    match ty {
        1 => Some((2, 1, "line")),
        3 => Some((4, 2, "quadrangle")),
        5 => Some((8, 3, "hexahedron")),
        15 => Some((1, 0, "point")),
        _ => None,
    }
}

/// Reserves room for `n` more entries (a count read from the file), failing cleanly instead of
/// aborting when the memory is not there.
fn reserve<T>(
    v: &mut Vec<T>,
    n: usize,
    err: impl FnOnce(String) -> MeshError,
) -> Result<(), MeshError> {
    v.try_reserve(n).map_err(|e| {
        err(format!(
            "cannot allocate memory for {n} entries ({e}): the file claims more than this machine holds"
        ))
    })
}

/// An element block of `$Elements` with its elements' node numbers (already mapped to mesh
/// node indices) and source lines.
struct Block {
    dim: usize,
    entity: i64,
    ty: i64,
    /// [n_elems][nodes_per_element]
    nodes: Vec<u32>,
    /// element tags and lines, [n_elems]
    tags: Vec<i64>,
    lines: Vec<usize>,
}

/// [`parse_gmsh`] with the warnings of [`read_gmsh_with_warnings`].
///
/// Every count the file gives (entities, node and element blocks, their entries) is checked
/// against what the rest of its section can hold before anything is allocated, and allocation is
/// fallible; the header totals must equal the sum of the blocks, and no data may follow the last
/// block. Cells are checked by [`Mesh::validate`] (inverted, collapsed or duplicate cells), with
/// the error naming the element's line and tag.
pub fn parse_gmsh_with_warnings<'a>(
    text: &'a str,
    path: &'a str,
) -> Result<(Mesh, Vec<String>), MeshError> {
    let mut warnings = Vec::new();
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
        if let Some((line, text)) = lines.next() {
            return Err(err(
                *line,
                format!("unexpected '{text}': $PhysicalNames announces {n} names, and holds more"),
            ));
        }
    }

    // entity (dim, tag) -> physical tags
    let mut entity_physicals: HashMap<(usize, i64), Vec<i64>> = HashMap::new();
    if let Some(sec) = sections.iter().find(|s| s.name == "Entities") {
        let mut c = cursor(sec);
        let mut counts = [0usize; 4];
        for (d, n) in counts.iter_mut().enumerate() {
            // a point has tag, x y z and a physical count; a higher entity a bounding box and a
            // bounding count too
            let least = if d == 0 { 5 } else { 9 };
            *n = c
                .count_fitting(&format!("number of entities of dimension {d}"), least)?
                .1;
        }
        for (d, &n) in counts.iter().enumerate() {
            for _ in 0..n {
                let (_, tag) = c.int("entity tag")?;
                c.skip(if d == 0 { 3 } else { 6 }, "entity coordinates")?;
                let (line, n_phys) = c.count_fitting("number of physical tags", 1)?;
                let mut tags = Vec::new();
                reserve(&mut tags, n_phys, |m| err(line, m))?;
                for _ in 0..n_phys {
                    let (line, t) = c.int("physical tag")?;
                    // a negative tag is the group's with the entity's orientation reversed; this
                    // one has no positive counterpart
                    if t == i64::MIN {
                        return Err(err(line, format!("physical tag {t} is out of range")));
                    }
                    tags.push(t);
                }
                entity_physicals.insert((d, tag), tags);
                if d > 0 {
                    let n_bound = c.count_fitting("number of bounding entities", 1)?.1;
                    c.skip(n_bound, "bounding entity tag")?;
                }
            }
        }
        c.expect_end(
            "Entities",
            &format!("announces {counts:?} entities of dimensions 0..3"),
        )?;
    }

    // nodes: tag -> index in order of appearance, coordinates [n][3]
    let nodes_sec = sections
        .iter()
        .find(|s| s.name == "Nodes")
        .ok_or_else(|| err(1, "no $Nodes section".into()))?;
    let mut node_index: HashMap<i64, u32> = HashMap::new();
    let mut xyz: Vec<f64> = Vec::new();
    let mut xyz_lines: Vec<usize> = Vec::new();
    // the tag of each node, in mesh node order
    let mut node_tags: Vec<i64> = Vec::new();
    {
        let mut c = cursor(nodes_sec);
        // a block header has 4 values, a node at least a tag and x y z
        let n_blocks = c.count_fitting("number of node blocks", 4)?.1;
        let (header_line, n_nodes) = c.count_fitting("number of nodes", 4)?;
        if n_nodes > u32::MAX as usize {
            return Err(err(
                header_line,
                format!(
                    "{n_nodes} nodes exceed the {} this reader numbers",
                    u32::MAX
                ),
            ));
        }
        c.skip(2, "min/max node tag")?;
        let at_header = |m| err(header_line, m);
        reserve(&mut xyz, 3 * n_nodes, at_header)?;
        reserve(&mut xyz_lines, n_nodes, at_header)?;
        reserve(&mut node_tags, n_nodes, at_header)?;
        node_index.try_reserve(n_nodes).map_err(|e| {
            at_header(format!(
                "cannot allocate memory for {n_nodes} nodes ({e}): the file claims more than this \
                 machine holds"
            ))
        })?;
        let mut n_read = 0usize;
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
            let (line, n) = c.count_fitting("number of nodes in block", 4)?;
            n_read += n;
            if n_read > n_nodes {
                return Err(err(
                    line,
                    format!(
                        "node blocks hold more nodes than the {n_nodes} that the $Nodes header \
                         (line {header_line}) announces"
                    ),
                ));
            }
            for _ in 0..n {
                let (line, tag) = c.int("node tag")?;
                let index = node_index.len() as u32;
                if node_index.insert(tag, index).is_some() {
                    return Err(err(line, format!("node tag {tag} defined twice")));
                }
                node_tags.push(tag);
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
        if n_read != n_nodes {
            return Err(err(
                header_line,
                format!(
                    "the $Nodes header announces {n_nodes} nodes, but its {n_blocks} blocks hold \
                     {n_read}"
                ),
            ));
        }
        c.expect_end(
            "Nodes",
            &format!("(line {header_line}) announces {n_blocks} blocks"),
        )?;
    }

    // element blocks
    let elems_sec = sections
        .iter()
        .find(|s| s.name == "Elements")
        .ok_or_else(|| err(1, "no $Elements section".into()))?;
    let mut blocks: Vec<Block> = Vec::new();
    {
        let mut c = cursor(elems_sec);
        // a block header has 4 values, an element at least a tag and one node
        let n_blocks = c.count_fitting("number of element blocks", 4)?.1;
        let (header_line, n_elems) = c.count_fitting("number of elements", 2)?;
        c.skip(2, "min/max element tag")?;
        let mut n_read = 0usize;
        for _ in 0..n_blocks {
            let dim = c.count("entity dimension")?;
            let (_, entity) = c.int("entity tag")?;
            let (line, ty) = c.int("element type")?;
            let (npe, elem_dim, elem_name) = element_shape(ty).ok_or_else(|| {
                err(
                    line,
                    format!(
                        "element type {ty} is not supported (only 1 line, 3 quad, 5 hex, 15 point)"
                    ),
                )
            })?;
            // a block's entity has the dimension of its elements: the mesh's dimension and its
            // cells are taken from the blocks
            if dim != elem_dim {
                return Err(err(
                    line,
                    format!(
                        "element type {ty} ({elem_name}) in a block of entity dimension {dim}: a \
                         {elem_name} has dimension {elem_dim}"
                    ),
                ));
            }
            let (line, n) = c.count_fitting("number of elements in block", 1 + npe)?;
            n_read += n;
            if n_read > n_elems {
                return Err(err(
                    line,
                    format!(
                        "element blocks hold more elements than the {n_elems} that the $Elements \
                         header (line {header_line}) announces"
                    ),
                ));
            }
            let mut block = Block {
                dim,
                entity,
                ty,
                nodes: Vec::new(),
                tags: Vec::new(),
                lines: Vec::new(),
            };
            // count_fitting bounds n * npe by the section's size
            reserve(&mut block.nodes, n * npe, |m| err(line, m))?;
            reserve(&mut block.tags, n, |m| err(line, m))?;
            reserve(&mut block.lines, n, |m| err(line, m))?;
            for _ in 0..n {
                let (line, tag) = c.int("element tag")?;
                block.tags.push(tag);
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
        if n_read != n_elems {
            return Err(err(
                header_line,
                format!(
                    "the $Elements header announces {n_elems} elements, but its {n_blocks} blocks \
                     hold {n_read}"
                ),
            ));
        }
        c.expect_end(
            "Elements",
            &format!("(line {header_line}) announces {n_blocks} blocks"),
        )?;
    }

    // the dimension of the highest non-empty cell block: its blocks hold at least one cell
    let dim = blocks
        .iter()
        .filter(|b| !b.tags.is_empty())
        .filter_map(|b| match b.ty {
            3 => Some(2),
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
        // before any geometric check, which a non-finite or huge coordinate would mislead
        if let Some((k, &v)) = p
            .iter()
            .enumerate()
            .find(|(_, v)| !super::coordinate_in_range(**v))
        {
            return Err(err(
                xyz_lines[n],
                format!(
                    "node {}: coordinate {} = {}",
                    node_tags[n],
                    ["x", "y", "z"][k],
                    super::coordinate_problem(v)
                ),
            ));
        }
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
    // (element tag, line) of each cell; a block of the mesh's dimension holds its cells (the
    // block's type is that dimension's, checked when the block was read)
    let mut cell_source: Vec<(i64, usize)> = Vec::new();
    for b in blocks.iter().filter(|b| b.dim == dim) {
        cell_source.extend(b.tags.iter().copied().zip(b.lines.iter().copied()));
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
    // Cell checks (inverted, collapsed, duplicate) are the mesh layer's; here they are told in the
    // file's terms: the element's line and tag, node tags.
    mesh.validate().map_err(|e| {
        let Some(c) = e.cell() else { return e };
        let (tag, line) = cell_source[c];
        let node_tag = |n: u32| node_tags[n as usize];
        let msg = match &e {
            MeshError::RepeatedNode { node, .. } => format!(
                "element {tag} lists node {} twice (a collapsed cell)",
                node_tag(*node)
            ),
            MeshError::CoincidentNodes { a, b, x, .. } => format!(
                "element {tag} has nodes {} and {} at the same point {x:?} (a collapsed cell)",
                node_tag(*a),
                node_tag(*b)
            ),
            MeshError::DuplicateCell { first, .. } => format!(
                "element {tag} duplicates element {} (line {}): same nodes",
                cell_source[*first].0, cell_source[*first].1
            ),
            e => format!("element {tag}: {e}"),
        };
        MeshError::Gmsh {
            path: path.to_string(),
            line,
            msg,
        }
    })?;
    let unused = mesh.unused_nodes();
    if !unused.is_empty() {
        let first: Vec<String> = unused
            .iter()
            .take(UNUSED_NODES_SHOWN)
            .map(|&n| node_tags[n as usize].to_string())
            .collect();
        warnings.push(format!(
            "{path}: {} node{} in no element (ignored, no unknowns): tag{} {}{}",
            unused.len(),
            if unused.len() == 1 { " is" } else { "s are" },
            if unused.len() == 1 { "" } else { "s" },
            first.join(", "),
            if unused.len() > first.len() {
                ", ..."
            } else {
                ""
            }
        ));
    }
    mesh.node_tags = node_tags;
    Ok((mesh, warnings))
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

    /// The line number of the first line equal to `l`.
    fn line_of(text: &str, l: &str) -> usize {
        text.lines().position(|x| x == l).unwrap() + 1
    }

    /// The error of parsing `text` must be a Gmsh error on the line that is `at` and contain `words`.
    fn fails_at(text: &str, at: &str, words: &str) {
        match parse_gmsh(text, "bad.msh") {
            Err(MeshError::Gmsh { line, msg, .. }) => {
                assert_eq!(line, line_of(text, at), "{msg}");
                assert!(msg.contains(words), "{msg}");
            }
            other => panic!("expected a Gmsh error containing '{words}', got {other:?}"),
        }
    }

    #[test]
    fn header_counts_must_agree_with_the_data() {
        let t = QUADS_2X1.replace("1 6 1 6", "1 7 1 6");
        fails_at(&t, "1 7 1 6", "announces 7 nodes, but its 1 blocks hold 6");
        let t = QUADS_2X1.replace("3 5 1 5", "3 6 1 6");
        fails_at(
            &t,
            "3 6 1 6",
            "announces 6 elements, but its 3 blocks hold 5",
        );
        let t = QUADS_2X1.replace("3 5 1 5", "3 4 1 5");
        fails_at(&t, "2 1 3 2", "more elements than the 4");
        // a block that claims more nodes than the section holds
        let t = QUADS_2X1.replace("2 1 0 6", "2 1 0 7");
        fails_at(&t, "2 1 0 7", "disagrees with the file");
        // data after the last announced block: a short count with a matching header
        let t = QUADS_2X1
            .replace("1 6 1 6", "1 5 1 5")
            .replace("2 1 0 6", "2 1 0 5")
            .replace("5\n6\n0 0 0", "5\n0 0 0");
        fails_at(&t, "0 1 0", "after the last block of $Nodes");
        let t = QUADS_2X1.replace("5 2 3 4 5\n", "5 2 3 4 5\n6 1 2 5 6\n");
        fails_at(&t, "6 1 2 5 6", "after the last block of $Elements");
        let t = QUADS_2X1.replace("2 3 \"body\"\n", "2 3 \"body\"\n2 4 \"extra\"\n");
        fails_at(&t, "2 4 \"extra\"", "announces 3 names");
    }

    #[test]
    fn absurd_counts_are_errors_before_any_allocation() {
        let huge = (1u64 << 62).to_string();
        for (from, to) in [
            ("1 6 1 6", format!("1 {huge} 1 6")),
            ("2 1 0 6", format!("2 1 0 {huge}")),
            ("3 5 1 5", format!("{huge} 5 1 5")),
            ("2 1 3 2", format!("2 1 3 {huge}")),
            ("1 1 1 2", format!("1 1 1 {huge}")),
            ("0 2 1 0", format!("0 {huge} 1 0")),
            ("1 2 1 1", format!("1 2 1 {}", u64::MAX)),
        ] {
            let t = QUADS_2X1.replacen(from, &to, 1);
            assert_ne!(t, QUADS_2X1);
            let e = parse_gmsh(&t, "huge.msh").unwrap_err().to_string();
            assert!(e.starts_with("huge.msh:"), "{from}: {e}");
            assert!(
                e.contains("disagrees with the file") || e.contains("expected integer"),
                "{from}: {e}"
            );
        }
    }

    #[test]
    fn duplicate_and_collapsed_elements_name_their_line_and_tag() {
        // element 6 lists the nodes of element 4 in another order
        let t = QUADS_2X1
            .replace("3 5 1 5", "3 6 1 6")
            .replace("2 1 3 2", "2 1 3 3")
            .replace("5 2 3 4 5\n", "5 2 3 4 5\n6 2 5 6 1\n");
        let dup_line = line_of(&t, "4 1 2 5 6");
        fails_at(
            &t,
            "6 2 5 6 1",
            &format!("element 6 duplicates element 4 (line {dup_line})"),
        );
        let t = QUADS_2X1.replace("5 2 3 4 5", "5 2 3 4 4");
        fails_at(
            &t,
            "5 2 3 4 4",
            "element 5 lists node 4 twice (a collapsed cell)",
        );
        // node 6 moved onto node 5: element 4 collapses to a triangle
        let t = QUADS_2X1.replace("1 1 0\n0 1 0\n", "1 1 0\n1 1 0\n");
        fails_at(
            &t,
            "4 1 2 5 6",
            "element 4 has nodes 5 and 6 at the same point",
        );
    }

    #[test]
    fn unused_nodes_are_a_warning_naming_their_tags() {
        let t = QUADS_2X1
            .replace("1 6 1 6", "1 8 1 8")
            .replace("2 1 0 6", "2 1 0 8")
            .replace("5\n6\n0 0 0", "5\n6\n17\n9\n0 0 0")
            .replace("0 1 0\n$EndNodes", "0 1 0\n7 7 0\n8 8 0\n$EndNodes");
        let (m, w) = parse_gmsh_with_warnings(&t, "extra.msh").unwrap();
        assert_eq!(m.n_nodes(), 8);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].contains("extra.msh: 2 nodes are in no element"),
            "{w:?}"
        );
        assert!(w[0].contains("tags 17, 9"), "{w:?}");
        let (_, w) = parse_gmsh_with_warnings(QUADS_2X1, "ok.msh").unwrap();
        assert!(w.is_empty(), "{w:?}");
    }

    #[test]
    fn an_element_in_a_block_of_another_dimension_is_an_error() {
        // a hexahedron in a surface block: it would make the mesh 3D without making a cell
        let t = ONE_HEX.replace("3 1 5 1\n", "2 1 5 1\n");
        fails_at(
            &t,
            "2 1 5 1",
            "element type 5 (hexahedron) in a block of entity dimension 2",
        );
        // quadrangles in a curve block
        let t = QUADS_2X1.replace("2 1 3 2\n", "1 1 3 2\n");
        fails_at(
            &t,
            "1 1 3 2",
            "element type 3 (quadrangle) in a block of entity dimension 1",
        );
        // a line in a point block
        let t = QUADS_2X1.replace("1 2 1 1\n", "0 2 1 1\n");
        fails_at(
            &t,
            "0 2 1 1",
            "element type 1 (line) in a block of entity dimension 0",
        );
    }

    #[test]
    fn a_mesh_without_cells_is_an_error() {
        // the only quadrangle block is empty: no cell, though the block's type is a cell's
        let start = QUADS_2X1.find("$Elements").unwrap();
        let t = format!(
            "{}$Elements\n1 0 1 0\n2 1 3 0\n$EndElements\n",
            &QUADS_2X1[..start]
        );
        fails_at(
            &t,
            "$Elements",
            "no quadrangle (type 3) or hexahedron (type 5) elements",
        );
    }

    #[test]
    fn a_physical_tag_without_a_magnitude_is_an_error() {
        // -i64::MIN does not exist: the tag cannot name a group
        let t = QUADS_2X1.replace(
            "2 2 0 0 2 1 0 1 2 0",
            &format!("2 2 0 0 2 1 0 1 {} 0", i64::MIN),
        );
        fails_at(
            &t,
            &format!("2 2 0 0 2 1 0 1 {} 0", i64::MIN),
            &format!("physical tag {} is out of range", i64::MIN),
        );
    }

    #[test]
    fn missing_file_error_names_the_path() {
        let p = std::path::Path::new("/nonexistent/dir/mesh.msh");
        let e = read_gmsh(p).unwrap_err();
        assert!(matches!(e, MeshError::Io { .. }));
        assert!(e.to_string().contains("/nonexistent/dir/mesh.msh"));
    }
}
