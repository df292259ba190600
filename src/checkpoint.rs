//! Checkpoints of a run and what a restart needs from them (`run --checkpoint-every N`,
//! `run CASE --restart DIR`).
//!
//! A checkpoint is a folder `DIR/checkpoints/step-NNNNNN/` written by rank 0 as
//! `step-NNNNNN.partial/` and renamed when complete (the previous checkpoint is removed only then,
//! so a valid one exists at every moment):
//! - `state.h5`: the resolved case (TOML text) and its hash, the load-step position and step-size
//!   state (with the secant predictor's), the displacement per node (global node numbering, so
//!   the rank count may change) and, for the secant predictor, the one of the step before, the
//!   element history per cell (Q1E4 enhanced parameters; global cell numbering), the committed
//!   contact state per quadrature point (keyed by pair, half-pass, surface element and point), and
//!   the run's log so far (Newton statistics, steps of summary.json);
//! - `results.h5`, `history.csv`: copies of the output as it stood after that step, which a restart
//!   continues (so a restarted run's files equal an uninterrupted run's).

use crate::io::{IoError, NewtonStats, StepLog};
use crate::solver::{LoadPosition, PredictorState};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Version of the checkpoint layout; a restart refuses any other (2: contact rows carry the
/// augmented Lagrangian multiplier).
const FORMAT: u32 = 2;

/// Folder of a run's checkpoints inside its output directory.
pub const CHECKPOINTS: &str = "checkpoints";

/// The run's record so far, kept as JSON in `state.h5`.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct RunLog {
    /// Newton statistics of the converged steps.
    pub newton: NewtonStats,
    /// The steps of summary.json.
    pub steps: Vec<StepLog>,
    /// Wall time of the run when the checkpoint was written (history.csv's clock continues).
    pub wall_time: f64,
    /// The results writer's description of results.h5 ([`crate::io::ResultsWriter::layout`]).
    pub results_layout: String,
    /// Restarts before the one that wrote this checkpoint.
    #[serde(default)]
    pub restarts: usize,
    /// (mesh name, file as given, hash of its contents) of every mesh the case reads from a file
    /// ([`mesh_hashes`]); a restart refuses changed files.
    #[serde(default)]
    pub mesh_hashes: Vec<(String, String, String)>,
}

/// (mesh name, file, FNV-1a 64 of its bytes) of every mesh `case` reads from a file. A file that
/// cannot be read hashes to the reason (the run itself will have failed on it).
pub fn mesh_hashes(case: &crate::scene::Case) -> Vec<(String, String, String)> {
    case.meshes
        .iter()
        .filter_map(|(name, m)| match m {
            crate::scene::MeshSpec::File(f) => {
                let path = case.resolve_path(&f.file);
                let hash = match std::fs::read(&path) {
                    Ok(bytes) => bytes_hash(&bytes),
                    Err(e) => format!("unreadable ({e})"),
                };
                Some((name.clone(), f.file.display().to_string(), hash))
            }
            crate::scene::MeshSpec::Generated(_) => None,
        })
        .collect()
}

/// Why the mesh files now (`now`, from [`mesh_hashes`]) cannot continue a checkpoint that read
/// `saved`: the first mesh whose file changed.
pub fn compare_meshes(
    saved: &[(String, String, String)],
    now: &[(String, String, String)],
) -> Result<(), String> {
    for (name, file, hash) in now {
        if let Some((_, _, was)) = saved.iter().find(|(n, f, _)| n == name && f == file) {
            if was != hash {
                return Err(format!(
                    "the mesh file `{file}` (`meshes.{name}`) changed since the checkpoint was written (contents hash {was} there, {hash} now)"
                ));
            }
        }
    }
    Ok(())
}

/// Meta data of `state.h5`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Meta {
    format: u32,
    case_hash: String,
    ranks: usize,
    element_history_width: usize,
    log: RunLog,
}

/// Everything a checkpoint holds, independent of the rank count.
#[derive(Debug, Clone)]
pub struct State {
    /// The resolved case as TOML.
    pub case_toml: String,
    /// Where the load stepping stands.
    pub position: LoadPosition,
    /// Displacement per node and component [n_nodes][dim] (0 at nodes without unknowns).
    pub displacement: Vec<f64>,
    /// The converged displacement of the step before, as `displacement`, when the secant
    /// predictor extrapolates from it (`position.predictor.last` is set); empty otherwise.
    pub displacement_before: Vec<f64>,
    /// Element history per cell of the model [n_cells][width] (empty: width 0).
    pub element_history: Vec<f64>,
    /// Values per cell in `element_history`.
    pub element_history_width: usize,
    /// Contact state, [`crate::contact::system::CHECKPOINT_ROW`] values per point.
    pub contact_points: Vec<f64>,
    /// Coupling blocks of the contact sparsity pattern, (pass, element, partner) per block, all
    /// ranks' (empty: none to keep, the restart builds its own).
    pub contact_pattern: Vec<f64>,
    /// Ranks that wrote the checkpoint (for information).
    pub ranks: usize,
    /// The log so far.
    pub log: RunLog,
}

/// FNV-1a 64 of the resolved case's text: stable across builds and platforms.
pub fn case_hash(text: &str) -> String {
    bytes_hash(text.as_bytes())
}

/// FNV-1a 64 of `bytes`, as 16 hex digits.
fn bytes_hash(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf29ce484222325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x100000001b3);
    }
    format!("{h:016x}")
}

fn h5err(path: &Path, what: &str) -> impl FnOnce(hdf5::Error) -> IoError {
    let path = path.to_path_buf();
    let what = what.to_string();
    move |source| IoError::Hdf5 { path, what, source }
}

fn file_err(path: &Path, op: &'static str) -> impl FnOnce(std::io::Error) -> IoError {
    let path = path.to_path_buf();
    move |source| IoError::File { path, op, source }
}

/// Writes `state.h5` at `path`.
fn write_state(path: &Path, s: &State) -> Result<(), IoError> {
    let f = hdf5::File::create(path).map_err(h5err(path, "the file"))?;
    let meta = Meta {
        format: FORMAT,
        case_hash: case_hash(&s.case_toml),
        ranks: s.ranks,
        element_history_width: s.element_history_width,
        log: s.log.clone(),
    };
    let json = serde_json::to_string(&meta).map_err(|e| IoError::Invalid {
        what: path.display().to_string(),
        message: e.to_string(),
    })?;
    let p = &s.position;
    let mut position = vec![p.step as f64, p.stage as f64, p.lambda, p.dl];
    position.extend(p.predictor.values());
    let bytes: [(&str, &[u8]); 2] = [
        ("case_toml", s.case_toml.as_bytes()),
        ("meta", json.as_bytes()),
    ];
    for (name, b) in bytes {
        f.new_dataset::<u8>()
            .shape([b.len()])
            .create(name)
            .and_then(|d| d.write_raw(b))
            .map_err(h5err(path, name))?;
    }
    let floats: [(&str, &[f64]); 6] = [
        ("contact_pattern", &s.contact_pattern),
        ("position", &position),
        ("displacement", &s.displacement),
        ("displacement_before", &s.displacement_before),
        ("element_history", &s.element_history),
        ("contact_points", &s.contact_points),
    ];
    for (name, v) in floats {
        // an empty dataset is simply absent
        if v.is_empty() {
            continue;
        }
        f.new_dataset::<f64>()
            .shape([v.len()])
            .create(name)
            .and_then(|d| d.write_raw(v))
            .map_err(h5err(path, name))?;
    }
    f.close().map_err(h5err(path, "the file (close)"))?;
    Ok(())
}

/// The values of a checkpoint's `position` dataset that no run writes: `p` is the dataset (step,
/// stage, load, increment, and the secant predictor's six values when there are ten), `n_stages`
/// the stages of the case the checkpoint was written for. A run's checkpoint stands at a whole
/// number of steps, at a stage no later than the case's last (its number when all are done), at a
/// load inside that stage (from its start, up to its end), with a positive increment of at most a
/// whole stage.
pub fn position_problem(p: &[f64], n_stages: usize) -> Option<String> {
    let whole = |x: f64| x.is_finite() && x >= 0.0 && x.fract() == 0.0 && x < 9.0e15;
    let (step, stage, lambda, dl) = (p[0], p[1], p[2], p[3]);
    if !whole(step) {
        return Some(format!("the step count {step} is not a whole number >= 0"));
    }
    if !whole(stage) {
        return Some(format!("the stage {stage} is not a whole number >= 0"));
    }
    if stage > n_stages as f64 {
        return Some(format!(
            "the stage {stage} is beyond the case's {n_stages} stage{}",
            if n_stages == 1 { "" } else { "s" }
        ));
    }
    let end = if stage == n_stages as f64 {
        stage
    } else {
        stage + 1.0
    };
    let slack = 1e-9 * end.max(1.0);
    if !lambda.is_finite() || lambda < stage - slack || lambda > end + slack {
        return Some(format!(
            "the load {lambda} is outside its stage {stage} (from {stage} to {end})"
        ));
    }
    if !dl.is_finite() || dl <= 0.0 || dl > 1.0 {
        return Some(format!(
            "the load increment {dl} is not in (0, 1] (a stage's load runs over 1)"
        ));
    }
    if p.len() == 10 {
        let (last, last_dl, pstage, tried, failed, given_up) = (p[4], p[5], p[6], p[7], p[8], p[9]);
        let index = |x: f64| x == -1.0 || (whole(x) && x <= stage);
        if !index(last) || !index(pstage) {
            return Some(format!(
                "the secant predictor's stages ({last}, {pstage}) are not -1 or a stage up to {stage}"
            ));
        }
        if !last_dl.is_finite() || !(0.0..=1.0).contains(&last_dl) {
            return Some(format!(
                "the secant predictor's last increment {last_dl} is not in [0, 1]"
            ));
        }
        if !whole(tried) || !whole(failed) || failed > tried {
            return Some(format!(
                "the secant predictor's counts ({tried} tried, {failed} failed) are not whole \
                 numbers with failed <= tried"
            ));
        }
        if given_up != 0.0 && given_up != 1.0 {
            return Some(format!(
                "the secant predictor's flag {given_up} is neither 0 nor 1"
            ));
        }
    }
    None
}

/// The first value of `v` that is not finite, as "value i is x".
fn not_finite(v: &[f64]) -> Option<String> {
    v.iter()
        .position(|x| !x.is_finite())
        .map(|i| format!("value {i} is {}", v[i]))
}

/// Reads a checkpoint's `state.h5` and checks what it holds: every dataset a run writes is there
/// and readable, the stored case matches its hash, the position is one a run of that case reaches
/// ([`position_problem`]) and every field value is finite. A bad checkpoint is an error naming the
/// file and the dataset.
pub fn read_state(checkpoint: &Path) -> Result<State, IoError> {
    let path = checkpoint.join("state.h5");
    let invalid = |message: String| IoError::Invalid {
        what: path.display().to_string(),
        message,
    };
    let bad = |dataset: &str, message: String| {
        invalid(format!("a bad checkpoint: dataset `{dataset}`: {message}"))
    };
    if !path.is_file() {
        return Err(invalid(format!(
            "a bad checkpoint: {} has no state.h5 (a run writes it into every checkpoint)",
            checkpoint.display()
        )));
    }
    let f = hdf5::File::open(&path).map_err(|e| {
        invalid(format!(
            "a bad checkpoint: HDF5 error while reading the file: {e}"
        ))
    })?;
    let read_error = |name: &str, e: hdf5::Error| {
        invalid(format!(
            "a bad checkpoint: HDF5 error while reading dataset `{name}`: {e}"
        ))
    };
    let bytes = |name: &str| -> Result<Vec<u8>, IoError> {
        f.dataset(name)
            .and_then(|d| d.read_raw::<u8>())
            .map_err(|e| read_error(name, e))
    };
    let floats = |name: &str| -> Result<Vec<f64>, IoError> {
        if !f.link_exists(name) {
            return Ok(Vec::new());
        }
        let v = f
            .dataset(name)
            .and_then(|d| d.read_raw::<f64>())
            .map_err(|e| read_error(name, e))?;
        match not_finite(&v) {
            Some(m) => Err(bad(name, m)),
            None => Ok(v),
        }
    };
    let case_toml = String::from_utf8(bytes("case_toml")?)
        .map_err(|_| bad("case_toml", "the case is not UTF-8".into()))?;
    let meta: Meta = serde_json::from_slice(&bytes("meta")?)
        .map_err(|e| bad("meta", format!("meta data: {e}")))?;
    if meta.format != FORMAT {
        return Err(invalid(format!(
            "checkpoint format {} (this build reads {FORMAT})",
            meta.format
        )));
    }
    if meta.case_hash != case_hash(&case_toml) {
        return Err(bad(
            "case_toml",
            "the stored case does not match its hash in `meta`".into(),
        ));
    }
    let p = floats("position")?;
    // 4 values: written before the secant predictor's state was kept (its first step after the
    // restart is not predicted)
    let predictor = match p.len() {
        4 => PredictorState::default(),
        10 => PredictorState::from_values(&[p[4], p[5], p[6], p[7], p[8], p[9]]),
        n => return Err(bad("position", format!("{n} values, not 10 (or 4)"))),
    };
    let n_stages = toml::from_str::<crate::scene::Case>(&case_toml)
        .map_err(|e| bad("case_toml", format!("the case does not parse: {e}")))?
        .stages
        .len();
    if let Some(m) = position_problem(&p, n_stages) {
        return Err(bad("position", m));
    }
    let contact_pattern = floats("contact_pattern")?;
    if !contact_pattern.len().is_multiple_of(3)
        || contact_pattern
            .iter()
            .any(|&v| v < 0.0 || v.fract() != 0.0 || v > f64::from(u32::MAX))
    {
        return Err(bad(
            "contact_pattern",
            "not (pass, element, partner) triples of whole numbers".into(),
        ));
    }
    let mut position = LoadPosition {
        step: p[0] as usize,
        stage: p[1] as usize,
        lambda: p[2],
        dl: p[3],
        predictor,
    };
    let displacement_before = floats("displacement_before")?;
    if displacement_before.is_empty() {
        position.predictor.last = None;
    }
    Ok(State {
        case_toml,
        position,
        displacement: floats("displacement")?,
        displacement_before,
        element_history: floats("element_history")?,
        element_history_width: meta.element_history_width,
        contact_points: floats("contact_points")?,
        contact_pattern,
        ranks: meta.ranks,
        log: meta.log,
    })
}

/// Rank 0: writes the checkpoint of `state` into `out_dir/checkpoints/step-NNNNNN/` with copies of
/// `results` (flushed) and `history`, then removes the older checkpoints. Returns the folder and
/// its size in bytes.
pub fn write(
    out_dir: &Path,
    state: &State,
    results: Option<&Path>,
    history: &Path,
) -> Result<(PathBuf, u64), IoError> {
    let root = out_dir.join(CHECKPOINTS);
    std::fs::create_dir_all(&root).map_err(file_err(&root, "create"))?;
    let name = format!("step-{:06}", state.position.step);
    let dir = root.join(&name);
    let tmp = root.join(format!("{name}.partial"));
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).map_err(file_err(&tmp, "remove an unfinished checkpoint"))?;
    }
    std::fs::create_dir_all(&tmp).map_err(file_err(&tmp, "create"))?;
    write_state(&tmp.join("state.h5"), state)?;
    let mut copies = vec![(history, "history.csv")];
    if let Some(r) = results {
        copies.push((r, "results.h5"));
    }
    for (from, to) in copies {
        std::fs::copy(from, tmp.join(to)).map_err(file_err(from, "copy into a checkpoint"))?;
    }
    let mut bytes = 0;
    for entry in std::fs::read_dir(&tmp).map_err(file_err(&tmp, "list"))? {
        let p = entry.map_err(file_err(&tmp, "list"))?.path();
        let f = std::fs::File::open(&p).map_err(file_err(&p, "open"))?;
        // on disk before the rename makes the checkpoint visible
        f.sync_all().map_err(file_err(&p, "sync"))?;
        bytes += f.metadata().map(|m| m.len()).unwrap_or(0);
    }
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(file_err(&dir, "replace"))?;
    }
    std::fs::rename(&tmp, &dir).map_err(file_err(&dir, "rename the finished checkpoint onto"))?;
    if let Ok(d) = std::fs::File::open(&root) {
        let _ = d.sync_all();
    }
    for (step, old) in list(&root) {
        if step != state.position.step {
            std::fs::remove_dir_all(&old).map_err(file_err(&old, "remove an older checkpoint"))?;
        }
    }
    Ok((dir, bytes))
}

/// Complete checkpoints in `root` (`step-NNNNNN`, not `.partial`), by step.
fn list(root: &Path) -> Vec<(usize, PathBuf)> {
    let mut out: Vec<(usize, PathBuf)> = std::fs::read_dir(root)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let step = name.strip_prefix("step-")?.parse().ok()?;
            e.path().is_dir().then(|| (step, e.path()))
        })
        .collect();
    out.sort();
    out
}

/// The last complete checkpoint in the run directory `dir`.
pub fn latest(dir: &Path) -> Result<PathBuf, String> {
    if !dir.is_dir() {
        return Err(format!("--restart {}: no such directory", dir.display()));
    }
    list(&dir.join(CHECKPOINTS))
        .pop()
        .map(|(_, p)| p)
        .ok_or_else(|| {
            format!(
                "--restart {}: no checkpoint in it (a run writes them into {}/{CHECKPOINTS}/ with --checkpoint-every N)",
                dir.display(),
                dir.display()
            )
        })
}

/// Stages (from the first) the checkpoint has started: they must not change on a restart.
pub fn stages_started(p: &LoadPosition) -> usize {
    p.stage + usize::from(p.stage_started())
}

/// Why the case `now` cannot continue a checkpoint of `saved` (both resolved cases as TOML), or
/// the `[solver]` settings that differ (`` `solver.key` (was there, is now) ``, empty when none)
/// when the cases differ only in those, in output settings and in stages the checkpoint has not
/// started (with the per-stage values of those stages in boundary conditions and contact pairs).
///
/// `[solver]` is how the problem is solved, not the problem (tolerances, the linear route, the
/// penetration bound of the iterates, the contact pattern's reach, the partition), as are the PETSc
/// options of the command line: continuing a failed run with other solver settings is what a
/// restart is for, so they may change, and the caller reports them.
pub fn compare_cases(saved: &str, now: &str, started: usize) -> Result<Vec<String>, String> {
    // through the schema, which knows its per-stage lists ([`Case::truncate_stages`]), then
    // compared as TOML trees so that the first differing key can be named
    let trimmed = |t: &str| -> Result<(toml::Value, toml::Value), String> {
        let mut case: crate::scene::Case =
            toml::from_str(t).map_err(|e| format!("the case does not parse: {e}"))?;
        case.truncate_stages(started);
        // a formulation spelled as its name or as its keys is one formulation
        for c in &mut case.contact {
            *c = c.canonical();
        }
        let mut v = toml::Value::try_from(&case).map_err(|e| e.to_string())?;
        let mut solver = toml::Value::Table(Default::default());
        if let Some(t) = v.as_table_mut() {
            t.remove("output");
            if let Some(s) = t.remove("solver") {
                solver = s;
            }
        }
        Ok((v, solver))
    };
    let ((a, sa), (b, sb)) = (trimmed(saved)?, trimmed(now)?);
    if let Some((key, was, is)) = first_difference(&a, &b, "") {
        return Err(format!(
            "`{key}` differs from the case the checkpoint was written for ({was} there, {is} now); only `output`, `solver` and the stages after the first {started} (those the checkpoint has started) may change"
        ));
    }
    let mut changed = Vec::new();
    if let (Some(x), Some(y)) = (sa.as_table(), sb.as_table()) {
        let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
        keys.sort();
        keys.dedup();
        for k in keys {
            let (u, v) = (x.get(k), y.get(k));
            if u != v {
                changed.push(format!("`solver.{k}` ({} there, {} now)", show(u), show(v)));
            }
        }
    }
    Ok(changed)
}

fn show(v: Option<&toml::Value>) -> String {
    match v {
        None => "absent".to_string(),
        Some(v) => {
            let s = v.to_string();
            if s.len() > 60 {
                format!("{}...", &s[..s.floor_char_boundary_compat(57)])
            } else {
                s
            }
        }
    }
}

/// `str::floor_char_boundary` for older toolchains.
trait FloorBoundary {
    fn floor_char_boundary_compat(&self, i: usize) -> usize;
}

impl FloorBoundary for str {
    fn floor_char_boundary_compat(&self, mut i: usize) -> usize {
        while i > 0 && !self.is_char_boundary(i) {
            i -= 1;
        }
        i
    }
}

/// The first key (dotted path, array indices as numbers) whose values differ: (key, a's, b's).
fn first_difference(
    a: &toml::Value,
    b: &toml::Value,
    path: &str,
) -> Option<(String, String, String)> {
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    match (a, b) {
        (toml::Value::Table(x), toml::Value::Table(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(u), Some(v)) => first_difference(u, v, &join(k)),
                (u, v) => Some((join(k), show(u), show(v))),
            })
        }
        (toml::Value::Array(x), toml::Value::Array(y)) => {
            (0..x.len().max(y.len())).find_map(|i| match (x.get(i), y.get(i)) {
                (Some(u), Some(v)) => first_difference(u, v, &join(&i.to_string())),
                (u, v) => Some((join(&i.to_string()), show(u), show(v))),
            })
        }
        _ if a == b => None,
        _ => Some((path.to_string(), show(Some(a)), show(Some(b)))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A case with every kind of per-stage list: a displacement's values, a rotation's angles
    /// and translations, a contact pair's friction switches and its rigid partner's motion.
    const CASE: &str = r#"
[case]
name = "c"
dim = 2
[meshes.m]
generator = "rectangle"
origin = [0.0, 0.0]
size = [1.0, 1.0]
divisions = [2, 2]
[bodies.b]
mesh = "m"
element = "Q1C1"
[bodies.b.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[[bcs]]
body = "b"
set = "top"
kind = "displacement"
value = [[0.1], [0.2]]
[[bcs]]
body = "b"
set = "left"
kind = "rotation"
center = [0.0, 0.0]
angle_deg = [1.0, 2.0]
translation = [[0.0, 0.1], [0.0, 0.2]]
[[contact]]
surfaces = ["b.bottom"]
rigid = { shape = "plane", point = [0.0, 0.0], normal = [0.0, 1.0], translation = [[0.0, 0.0], [0.1, 0.0]], rotation_deg = [0.0, 5.0] }
law = "penalty"
eps_n = 100.0
mu = 0.3
friction_stages = [false, true]
[[stages]]
name = "s0"
steps = 4
[[stages]]
name = "s1"
steps = 2
[output]
every = 1
"#;

    #[test]
    fn output_and_later_stages_may_change_nothing_else() {
        // every per-stage list may change in the second stage when only the first has started
        let changes = [
            ("steps = 2", "steps = 8"),
            ("[0.2]]", "[0.3]]"),
            ("[1.0, 2.0]", "[1.0, 3.0]"),
            ("[0.0, 0.2]]", "[0.0, 0.3]]"),
            ("[false, true]", "[false, false]"),
            ("[0.1, 0.0]]", "[0.2, 0.0]]"),
            ("[0.0, 5.0]", "[0.0, 6.0]"),
        ];
        let keys = [
            "`stages.1.steps`",
            "`bcs.0.value.1.0`",
            "`bcs.1.angle_deg.1`",
            "`bcs.1.translation.1.1`",
            "`contact.0.friction_stages.1`",
            "`contact.0.rigid.translation.1.0`",
            "`contact.0.rigid.rotation_deg.1`",
        ];
        for ((from, to), key) in changes.iter().zip(keys) {
            assert!(CASE.contains(from), "{from}");
            let later = CASE.replace("every = 1", "every = 5").replacen(from, to, 1);
            assert_eq!(compare_cases(CASE, &later, 1), Ok(vec![]), "{from} -> {to}");
            let err = compare_cases(CASE, &later, 2).unwrap_err();
            assert!(err.starts_with(&format!("{key} differs")), "{err}");
        }
        // solver settings are not the problem: they may change, and are reported
        let tuned = CASE.replace(
            "[output]",
            "[solver]\nmax_penetration = 0.05\nlinear = \"iterative\"\n[output]",
        );
        let changed = compare_cases(CASE, &tuned, 2).unwrap();
        assert_eq!(changed.len(), 2, "{changed:?}");
        assert!(
            changed
                .iter()
                .any(|c| c.starts_with("`solver.max_penetration` (") && c.ends_with("0.05 now)")),
            "{changed:?}"
        );
        assert!(
            changed.iter().any(|c| c.starts_with("`solver.linear`")),
            "{changed:?}"
        );
        assert_eq!(compare_cases(&tuned, &tuned, 2), Ok(vec![]));
        let e = CASE.replace("E = 1.0", "E = 2.0");
        let err = compare_cases(CASE, &e, 1).unwrap_err();
        assert!(err.contains("`bodies.b.material.E`"), "{err}");
        assert!(err.contains("1.0 there, 2.0 now"), "{err}");
        // a stage appended to a finished run
        let more = format!("{CASE}\n[[stages]]\nname = \"s2\"\nsteps = 3\n")
            .replace("[0.2]]", "[0.2], [0.4]]")
            .replace("[1.0, 2.0]", "[1.0, 2.0, 3.0]");
        assert_eq!(compare_cases(CASE, &more, 2), Ok(vec![]));
        let err = compare_cases(&more, CASE, 3).unwrap_err();
        assert!(err.contains("`bcs.0.value.2`"), "{err}");
        assert!(err.contains("stages after the first 3"), "{err}");
    }

    #[test]
    fn a_formulation_spelled_by_name_or_by_keys_continues_one_checkpoint() {
        let law = "law = \"penalty\"\neps_n = 100.0";
        for spelled in [
            "algorithm = \"two_half_pass\"",
            "formulation = \"paper\"",
            "gap = \"pointwise\"",
        ] {
            let now = CASE.replacen(law, &format!("{law}\n{spelled}"), 1);
            assert_ne!(now, CASE);
            assert_eq!(compare_cases(CASE, &now, 1), Ok(vec![]), "{spelled}");
        }
        let keys = CASE.replacen(
            law,
            &format!("{law}\nalgorithm = \"one_pass\"\ngap = \"weighted\""),
            1,
        );
        let named = CASE.replacen(law, &format!("{law}\nformulation = \"weighted_gap\""), 1);
        assert_eq!(compare_cases(&keys, &named, 1), Ok(vec![]));
        let err = compare_cases(CASE, &named, 1).unwrap_err();
        assert!(err.contains("`contact.0.algorithm`"), "{err}");
    }

    #[test]
    fn positions_no_run_reaches_are_named() {
        let ok = |p: &[f64]| position_problem(p, 2);
        // mid-stage, at a stage's start, all done, and with the predictor's values
        assert_eq!(ok(&[3.0, 0.0, 0.75, 0.25]), None);
        assert_eq!(ok(&[4.0, 1.0, 1.0, 0.5]), None);
        assert_eq!(ok(&[6.0, 2.0, 2.0, 0.5]), None);
        assert_eq!(
            ok(&[3.0, 0.0, 0.75, 0.25, 0.0, 0.25, 0.0, 2.0, 1.0, 0.0]),
            None
        );
        let says = |p: &[f64], what: &str| {
            let m = ok(p).unwrap_or_default();
            assert!(m.contains(what), "{p:?}: {m}");
        };
        says(&[1e20, 0.0, 0.5, 0.25], "step count");
        says(&[2.5, 0.0, 0.5, 0.25], "step count");
        says(
            &[3.0, 7.0, 7.5, 0.25],
            "the stage 7 is beyond the case's 2 stages",
        );
        says(
            &[3.0, 0.0, 1.6, 0.25],
            "the load 1.6 is outside its stage 0",
        );
        says(&[6.0, 2.0, 2.5, 0.25], "outside its stage 2 (from 2 to 2)");
        says(&[3.0, 0.0, f64::NAN, 0.25], "the load NaN");
        says(&[3.0, 0.0, 0.5, -0.1], "the load increment -0.1");
        says(&[3.0, 0.0, 0.5, 0.0], "the load increment 0");
        says(
            &[3.0, 0.0, 0.75, 0.25, 1.0, 0.25, 0.0, 2.0, 1.0, 0.0],
            "predictor's stages",
        );
        says(
            &[3.0, 0.0, 0.75, 0.25, 0.0, 0.25, 0.0, 2.0, 3.0, 0.0],
            "failed <= tried",
        );
    }

    #[test]
    fn a_stage_is_started_once_the_load_passed_its_start() {
        let p = |stage, lambda| LoadPosition {
            step: 1,
            stage,
            lambda,
            dl: 0.25,
            predictor: Default::default(),
        };
        assert_eq!(stages_started(&p(0, 0.25)), 1);
        assert_eq!(stages_started(&p(1, 1.0)), 1);
        assert_eq!(stages_started(&p(1, 1.5)), 2);
    }

    #[test]
    fn state_round_trips_and_only_complete_checkpoints_count() {
        let dir = std::env::temp_dir().join(format!("ckpt_rt_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let history = dir.join("history.csv");
        std::fs::write(&history, "step\n1\n").unwrap();
        let mut s = State {
            case_toml: CASE.to_string(),
            position: LoadPosition {
                step: 3,
                stage: 0,
                lambda: 0.1 + 0.2,
                dl: 1.0 / 3.0,
                predictor: PredictorState {
                    last: Some((0, 0.1 / 3.0)),
                    stage: Some(0),
                    tried: 9,
                    failed: 2,
                    given_up: true,
                },
            },
            displacement: vec![0.1, -2.5e-17, 3.0],
            displacement_before: vec![0.05, 1e-300, 2.0],
            element_history: Vec::new(),
            element_history_width: 0,
            contact_points: vec![1.0; 16],
            contact_pattern: vec![0.0, 3.0, 4.0],
            ranks: 2,
            log: RunLog::default(),
        };
        write(&dir, &s, None, &history).unwrap();
        s.position.step = 6;
        s.displacement[0] = 0.7;
        let (latest_dir, bytes) = write(&dir, &s, None, &history).unwrap();
        assert!(bytes > 0);
        // an unfinished later checkpoint is ignored
        std::fs::create_dir_all(dir.join("checkpoints/step-000009.partial")).unwrap();
        assert_eq!(latest(&dir).unwrap(), latest_dir);
        assert!(!dir.join("checkpoints/step-000003").exists());
        let back = read_state(&latest_dir).unwrap();
        assert_eq!(back.position, s.position);
        assert_eq!(back.displacement, s.displacement);
        assert_eq!(back.displacement_before, s.displacement_before);
        // without the state before, the predictor has nothing to extrapolate from
        s.displacement_before.clear();
        let again = write(&dir, &s, None, &history).unwrap().0;
        let back = read_state(&again).unwrap();
        assert_eq!(back.position.predictor.last, None);
        assert_eq!(back.position.predictor.tried, 9);
        assert_eq!(back.contact_points, s.contact_points);
        assert_eq!(back.contact_pattern, s.contact_pattern);
        assert!(back.element_history.is_empty());
        assert_eq!(back.case_toml, CASE);
        assert!(latest(&dir.join("nothing")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
