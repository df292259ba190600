//! The study file: schema (serde, unknown keys rejected), semantic checks naming the key, and the
//! runs it resolves to (the cartesian product of its axes).

use crate::study::metrics::MetricSpec;
use crate::study::StudyError;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A study file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudySpec {
    /// Name of the study (default: the file name without `.toml`).
    #[serde(default)]
    pub name: Option<String>,
    /// One line on what the study measures, repeated in `study.md`.
    #[serde(default)]
    pub description: String,
    /// The base case, relative to the study file.
    pub case: PathBuf,
    /// Runs executed at once. Default 1.
    #[serde(default = "one")]
    pub jobs: usize,
    /// MPI ranks of each run (`mpirun --oversubscribe -np ranks`; 1 runs the solver directly). Default 1.
    #[serde(default = "one")]
    pub ranks: usize,
    /// Longest a run may take, seconds; a run past it is stopped and recorded as failed. Default: none.
    #[serde(default)]
    pub timeout: Option<f64>,
    /// `--set` overrides given to every run, before the axes' own.
    #[serde(default)]
    pub set: Vec<String>,
    /// The axes swept; every combination of their values is one run.
    pub axes: Vec<AxisSpec>,
    /// The axis whose values are the series of the plots and the columns of the tables
    /// (default: the first axis).
    #[serde(default)]
    pub series: Option<String>,
    /// The axis on the abscissa of the metric-against-level plots (default: the other axis when there
    /// are two, none otherwise).
    #[serde(default)]
    pub level: Option<String>,
    /// A value of the series axis: `study.md` also gives every metric relative to the run with this
    /// value and the same other axis values, as the paper's tables do.
    #[serde(default)]
    pub reference: Option<String>,
    /// Metrics computed from each run's `history.csv`.
    #[serde(default)]
    pub metrics: Vec<MetricSpec>,
    /// Curves drawn for each run (its `history.csv` columns; a leading `-` negates).
    #[serde(default)]
    pub plot: PlotSpec,
    /// `[slurm]`: what the job script of `--launcher slurm` asks for (time, memory, partition, ...).
    #[serde(default)]
    pub slurm: Option<crate::study::slurm::SlurmSpec>,
}

fn one() -> usize {
    1
}

/// `[plot]`: the per-run curves.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    /// Columns drawn against `x`, one line each.
    #[serde(default)]
    pub curves: Vec<String>,
    /// Abscissa column of the curves. Default `load_factor`.
    #[serde(default)]
    pub x: Option<String>,
}

/// One axis: either the same value set to several keys (`keys` + `values`), or named bundles of
/// overrides (`levels`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisSpec {
    pub name: String,
    /// Case keys that each value is set to (e.g. the `element` of both contact bodies).
    #[serde(default)]
    pub keys: Vec<String>,
    /// Values, any TOML value.
    #[serde(default)]
    pub values: Vec<toml::Value>,
    /// Named bundles of overrides (a mesh level).
    #[serde(default)]
    pub levels: Vec<LevelSpec>,
}

/// One bundle of overrides on a `levels` axis.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LevelSpec {
    pub name: String,
    /// Its abscissa in the metric-against-level plots (e.g. elements per unit length); default: its
    /// position on the axis, from 1.
    #[serde(default)]
    pub value: Option<f64>,
    /// `--set` overrides of this level.
    #[serde(default)]
    pub set: Vec<String>,
}

/// A study ready to run: its file, case, the resolved runs.
#[derive(Debug, Clone)]
pub struct Study {
    pub file: PathBuf,
    pub name: String,
    pub spec: StudySpec,
    /// The base case, as a path usable from the current directory.
    pub case: PathBuf,
    /// Axis names, in order.
    pub axis_names: Vec<String>,
    /// Index of the series axis.
    pub series: usize,
    /// Index of the level axis, if any.
    pub level: Option<usize>,
    pub runs: Vec<RunSpec>,
}

/// One run of a study.
#[derive(Debug, Clone)]
pub struct RunSpec {
    /// Directory name (from the axis values).
    pub name: String,
    /// Label of each axis value, in axis order.
    pub labels: Vec<String>,
    /// Position of each axis value on its axis.
    pub index: Vec<usize>,
    /// Abscissa on the level axis.
    pub level_value: Option<f64>,
    /// All `--set` overrides of the run, in order.
    pub sets: Vec<String>,
}

impl Study {
    /// Reads, checks and resolves a study file.
    pub fn load(file: &Path) -> Result<Study, StudyError> {
        let text = std::fs::read_to_string(file).map_err(|source| StudyError::Io {
            path: file.to_path_buf(),
            op: "read the study file",
            source,
        })?;
        Self::parse(&text, file)
    }

    /// [`Study::load`] on text in memory; `file` names it in messages and anchors the case path.
    pub fn parse(text: &str, file: &Path) -> Result<Study, StudyError> {
        let spec: StudySpec = toml::from_str(text).map_err(|e| StudyError::Syntax {
            file: file.to_path_buf(),
            line: e.span().map(|s| {
                text.as_bytes()[..s.start.min(text.len())]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count()
                    + 1
            }),
            message: e.message().trim().to_string(),
        })?;
        let invalid = |key: &str, message: String| StudyError::Invalid {
            file: file.to_path_buf(),
            key: key.to_string(),
            message,
        };
        let name = match &spec.name {
            Some(n) => n.clone(),
            None => file
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "study".to_string()),
        };
        if !plain_name(&name) {
            return Err(invalid(
                "name",
                format!("`{name}` names the study's folder: use letters, digits, `-`, `_` and `.` only, and not `.` or `..`"),
            ));
        }
        if spec.jobs == 0 {
            return Err(invalid("jobs", "must be at least 1".into()));
        }
        if spec.ranks == 0 {
            return Err(invalid("ranks", "must be at least 1".into()));
        }
        if let Some(t) = spec.timeout {
            if t.is_nan() || t <= 0.0 {
                return Err(invalid("timeout", format!("must be positive, got {t}")));
            }
        }
        for (i, s) in spec.set.iter().enumerate() {
            check_set(s).map_err(|m| invalid(&format!("set.{i}"), m))?;
        }
        if spec.axes.is_empty() {
            return Err(invalid("axes", "a study needs at least one axis".into()));
        }
        // before anything that walks the values (some checks compare them pairwise)
        check_run_count(&spec).map_err(|m| invalid("axes", m))?;
        let mut axis_names: Vec<String> = Vec::new();
        for (a, axis) in spec.axes.iter().enumerate() {
            let key = format!("axes.{a}");
            if axis.name.is_empty() || !axis.name.chars().all(safe_char) {
                return Err(invalid(
                    &format!("{key}.name"),
                    format!(
                        "`{}`: use letters, digits, `-`, `_` and `.` only",
                        axis.name
                    ),
                ));
            }
            if axis_names.contains(&axis.name) {
                return Err(invalid(
                    &format!("{key}.name"),
                    format!("axis `{}` is declared twice", axis.name),
                ));
            }
            axis_names.push(axis.name.clone());
            match (axis.levels.is_empty(), axis.values.is_empty()) {
                (true, true) => {
                    return Err(invalid(
                        &key,
                        format!(
                            "axis `{}` has neither `values` (with `keys`) nor `levels`",
                            axis.name
                        ),
                    ))
                }
                (false, false) => {
                    return Err(invalid(
                        &key,
                        format!(
                            "axis `{}` has both `values` and `levels`; give one",
                            axis.name
                        ),
                    ))
                }
                (true, false) => {
                    if axis.keys.is_empty() {
                        return Err(invalid(
                            &format!("{key}.keys"),
                            format!(
                                "axis `{}` has `values` but no `keys` to set them to",
                                axis.name
                            ),
                        ));
                    }
                    for (k, ck) in axis.keys.iter().enumerate() {
                        if ck.is_empty() || ck.contains('=') || ck.split('.').any(str::is_empty) {
                            return Err(invalid(
                                &format!("{key}.keys.{k}"),
                                format!(
                                    "`{ck}` is not a case key path like `bodies.block.element`"
                                ),
                            ));
                        }
                    }
                }
                (false, true) => {
                    if !axis.keys.is_empty() {
                        return Err(invalid(
                            &format!("{key}.keys"),
                            format!(
                                "axis `{}` has `levels`: each level gives its own `set`, `keys` is for `values`",
                                axis.name
                            ),
                        ));
                    }
                    for (l, level) in axis.levels.iter().enumerate() {
                        for (i, s) in level.set.iter().enumerate() {
                            check_set(s)
                                .map_err(|m| invalid(&format!("{key}.levels.{l}.set.{i}"), m))?;
                        }
                    }
                }
            }
            let labels = axis_labels(axis);
            for (i, l) in labels.iter().enumerate() {
                if !plain_name(l) {
                    let what = if axis.levels.is_empty() {
                        format!("{key}.values.{i}")
                    } else {
                        format!("{key}.levels.{i}.name")
                    };
                    return Err(invalid(
                        &what,
                        format!(
                            "`{l}` names a run directory: use letters, digits, `-`, `_` and `.` only, and not `.` or `..`"
                        ),
                    ));
                }
                if labels[..i].contains(l) {
                    return Err(invalid(
                        &key,
                        format!("axis `{}` has the value `{l}` twice", axis.name),
                    ));
                }
            }
        }
        let find_axis = |key: &str, n: &str| {
            axis_names.iter().position(|a| a == n).ok_or_else(|| {
                invalid(
                    key,
                    format!("no axis `{n}` (axes: {})", axis_names.join(", ")),
                )
            })
        };
        let series = match &spec.series {
            Some(n) => find_axis("series", n)?,
            None => 0,
        };
        let level = match &spec.level {
            Some(n) => {
                let l = find_axis("level", n)?;
                if l == series {
                    return Err(invalid("level", format!("`{n}` is also the series axis")));
                }
                Some(l)
            }
            None if axis_names.len() == 2 => Some(1 - series),
            None => None,
        };
        if let Some(r) = &spec.reference {
            let labels = axis_labels(&spec.axes[series]);
            if !labels.contains(r) {
                return Err(invalid(
                    "reference",
                    format!(
                        "`{r}` is not a value of the series axis `{}` ({})",
                        axis_names[series],
                        labels.join(", ")
                    ),
                ));
            }
        }
        crate::study::metrics::validate(&spec.metrics)
            .map_err(|(key, message)| invalid(&key, message))?;
        if let Some(slurm) = &spec.slurm {
            slurm
                .validate()
                .map_err(|(key, message)| invalid(&key, message))?;
        }
        for (i, c) in spec.plot.curves.iter().enumerate() {
            if c.trim_start_matches('-').is_empty() {
                return Err(invalid(
                    &format!("plot.curves.{i}"),
                    "empty column name".into(),
                ));
            }
        }

        let case = if spec.case.is_absolute() {
            spec.case.clone()
        } else {
            file.parent().unwrap_or(Path::new("")).join(&spec.case)
        };
        if !case.is_file() {
            return Err(invalid(
                "case",
                format!("the case file {} does not exist", case.display()),
            ));
        }
        let runs = resolve_runs(&spec, level);
        check_run_names(&spec, &runs).map_err(|(key, m)| invalid(&key, m))?;
        Ok(Study {
            file: file.to_path_buf(),
            name,
            case,
            axis_names,
            series,
            level,
            runs,
            spec,
        })
    }
}

/// Runs a study may have: each is a process, a directory and a row of `study.csv`, and their names
/// are compared pairwise ([`check_run_names`]).
pub const MAX_RUNS: usize = 10_000;

/// The runs of the axes (the product of their sizes) are at most [`MAX_RUNS`].
fn check_run_count(spec: &StudySpec) -> Result<(), String> {
    let sizes: Vec<usize> = spec.axes.iter().map(axis_size).collect();
    let total = sizes.iter().try_fold(1usize, |t, &n| t.checked_mul(n));
    if total.is_some_and(|t| t <= MAX_RUNS) {
        return Ok(());
    }
    let runs = match total {
        Some(t) => t.to_string(),
        None => format!("more than {}", usize::MAX),
    };
    let axes: Vec<String> = spec
        .axes
        .iter()
        .zip(&sizes)
        .map(|(a, n)| format!("{} ({n} values)", a.name))
        .collect();
    Err(format!(
        "the axes {} make {runs} runs; a study holds at most {MAX_RUNS}",
        axes.join(" x ")
    ))
}

/// Values of an axis: its levels or its values (one of them is empty).
fn axis_size(axis: &AxisSpec) -> usize {
    axis.levels.len().max(axis.values.len())
}

/// Entries of a study's output folder besides its run directories.
const STUDY_ENTRIES: &[&str] = &[
    "logs",
    "plots",
    "study.csv",
    "study.md",
    "study.sbatch",
    "slurm-jobs.json",
    crate::io::LOCK_FILE,
];

/// A name that is one plain path component: not empty, `.` or `..`, and of [`safe_char`]s only.
fn plain_name(name: &str) -> bool {
    !name.is_empty() && name != "." && name != ".." && name.chars().all(safe_char)
}

/// Each run directory is one plain name, different from every other run's (also in letter case:
/// one folder on a case-insensitive file system) and from the study's own outputs; a clash names
/// the axis values of both runs.
fn check_run_names(spec: &StudySpec, runs: &[RunSpec]) -> Result<(), (String, String)> {
    let values = |r: &RunSpec| {
        let labels: Vec<String> = r.labels.iter().map(|l| format!("`{l}`")).collect();
        let keys: Vec<String> = r
            .index
            .iter()
            .enumerate()
            .map(|(a, &i)| {
                if spec.axes[a].levels.is_empty() {
                    format!("axes.{a}.values.{i}")
                } else {
                    format!("axes.{a}.levels.{i}.name")
                }
            })
            .collect();
        format!("{} ({})", labels.join(" + "), keys.join(", "))
    };
    for (i, r) in runs.iter().enumerate() {
        if !plain_name(&r.name) {
            return Err((
                "axes".into(),
                format!(
                    "the run of {} would write into `{}`, which is not a plain folder name",
                    values(r),
                    r.name
                ),
            ));
        }
        if let Some(e) = STUDY_ENTRIES
            .iter()
            .find(|e| e.eq_ignore_ascii_case(&r.name))
        {
            return Err((
                "axes".into(),
                format!(
                    "the run of {} would be named `{}`, as the study's own `{e}`; rename a value",
                    values(r),
                    r.name
                ),
            ));
        }
        if let Some(o) = runs[..i]
            .iter()
            .find(|o| o.name.eq_ignore_ascii_case(&r.name))
        {
            return Err((
                "axes".into(),
                format!(
                    "the runs of {} and of {} would share the run directory `{}`{}; rename a value so that the joined names differ",
                    values(o),
                    values(r),
                    r.name,
                    if o.name == r.name {
                        String::new()
                    } else {
                        format!(" (`{}` on a file system that ignores letter case)", o.name)
                    }
                ),
            ));
        }
    }
    Ok(())
}

fn safe_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.')
}

fn check_set(s: &str) -> Result<(), String> {
    match s.split_once('=') {
        Some((k, _)) if !k.trim().is_empty() => Ok(()),
        _ => Err(format!("`{s}` is not a `key.path=value` override")),
    }
}

/// The label of each value of an axis: a level's name, a string value itself, any other value as
/// TOML text.
pub fn axis_labels(axis: &AxisSpec) -> Vec<String> {
    if !axis.levels.is_empty() {
        return axis.levels.iter().map(|l| l.name.clone()).collect();
    }
    axis.values
        .iter()
        .map(|v| match v {
            toml::Value::String(s) => s.clone(),
            other => other
                .to_string()
                .chars()
                .map(|c| if safe_char(c) { c } else { '_' })
                .collect(),
        })
        .collect()
}

/// Every combination of the axes' values, the first axis varying slowest; their number is
/// bounded by [`check_run_count`].
fn resolve_runs(spec: &StudySpec, level: Option<usize>) -> Vec<RunSpec> {
    let sizes: Vec<usize> = spec.axes.iter().map(axis_size).collect();
    let labels: Vec<Vec<String>> = spec.axes.iter().map(axis_labels).collect();
    let total: usize = sizes.iter().product();
    let mut runs = Vec::with_capacity(total);
    for mut n in 0..total {
        let mut index = vec![0; sizes.len()];
        for a in (0..sizes.len()).rev() {
            index[a] = n % sizes[a];
            n /= sizes[a];
        }
        let mut sets = spec.set.clone();
        let mut level_value = None;
        for (a, axis) in spec.axes.iter().enumerate() {
            let i = index[a];
            if axis.levels.is_empty() {
                for k in &axis.keys {
                    sets.push(format!("{k}={}", axis.values[i]));
                }
            } else {
                sets.extend(axis.levels[i].set.iter().cloned());
            }
        }
        let run_labels: Vec<String> = (0..sizes.len())
            .map(|a| labels[a][index[a]].clone())
            .collect();
        if let Some(level) = level {
            let axis = &spec.axes[level];
            level_value = Some(
                axis.levels
                    .get(index[level])
                    .and_then(|l| l.value)
                    .or_else(|| match axis.values.get(index[level]) {
                        Some(toml::Value::Integer(i)) => Some(*i as f64),
                        Some(toml::Value::Float(f)) => Some(*f),
                        _ => None,
                    })
                    .unwrap_or((index[level] + 1) as f64),
            );
        }
        runs.push(RunSpec {
            name: run_labels.join("_"),
            labels: run_labels,
            index,
            level_value,
            sets,
        });
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Study, StudyError> {
        // the case must exist: anchor the (never written) study file in cases/
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/test.toml");
        Study::parse(text, &file)
    }

    const BASE: &str = r#"
case = "hertz_2d.toml"
[[axes]]
name = "family"
keys = ["bodies.disk.element"]
values = ["Q1N2", "Q1C1"]
[[axes]]
name = "mesh"
levels = [ { name = "coarse", value = 16, set = ["meshes.disk.n_arc=16"] },
           { name = "fine", set = ["meshes.disk.n_arc=32"] } ]
"#;

    #[test]
    fn runs_are_the_product_of_the_axes() {
        let s = parse(BASE).unwrap();
        assert_eq!(s.name, "test");
        let names: Vec<&str> = s.runs.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(
            names,
            ["Q1N2_coarse", "Q1N2_fine", "Q1C1_coarse", "Q1C1_fine"]
        );
        assert_eq!(
            s.runs[2].sets,
            ["bodies.disk.element=\"Q1C1\"", "meshes.disk.n_arc=16"]
        );
        assert_eq!((s.series, s.level), (0, Some(1)));
        assert_eq!(s.runs[0].level_value, Some(16.0));
        assert_eq!(s.runs[1].level_value, Some(2.0));
    }

    #[test]
    fn bad_files_name_the_key() {
        let cases: &[(&str, &str)] = &[
            ("jobs = 0\n", "`jobs`"),
            ("bogus = 1\n", "unknown field `bogus`"),
            ("series = \"size\"\n", "no axis `size`"),
            ("reference = \"Q1N9\"\n", "`reference`"),
        ];
        for (extra, want) in cases {
            let e = parse(&format!("{extra}{BASE}")).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains("test.toml"), "{extra}: {e}");
        }
        let e =
            parse("case = \"nope.toml\"\n[[axes]]\nname = \"a\"\nkeys = [\"x\"]\nvalues = [1]\n")
                .unwrap_err()
                .to_string();
        assert!(e.contains("`case`") && e.contains("does not exist"), "{e}");
        let e = parse("case = \"hertz_2d.toml\"\n[[axes]]\nname = \"a\"\nvalues = [1]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`axes.0.keys`"), "{e}");
        for (name, want) in [("..", "`name`"), (".", "`name`")] {
            let e = parse(&format!("name = \"{name}\"\n{BASE}"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(want) && e.contains("not `.` or `..`"), "{e}");
        }
        let e = parse(&BASE.replace("\"fine\"", "\"..\""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("`axes.1.levels.1.name`"), "{e}");
        let e = parse(&BASE.replace("\"fine\"", "\"coarse\""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("`coarse` twice"), "{e}");
    }

    #[test]
    fn more_runs_than_a_study_holds_are_refused_naming_the_axes() {
        // `axes` axes of `n` values each: n^axes runs
        let study = |axes: usize, n: usize| {
            let values: Vec<String> = (0..n).map(|i| i.to_string()).collect();
            let mut t = String::from("case = \"hertz_2d.toml\"\n");
            for a in 0..axes {
                t.push_str(&format!(
                    "[[axes]]\nname = \"a{a}\"\nkeys = [\"solver.max_iterations\"]\nvalues = [{}]\n",
                    values.join(", ")
                ));
            }
            t
        };
        // 1000^7 runs overflow a count; 300^4 = 8.1e9 do not, but are far too many to list
        for (axes, n, runs) in [
            (7, 1000, "more than 18446744073709551615"),
            (4, 300, "8100000000"),
            (3, 22, "10648"),
        ] {
            let e = parse(&study(axes, n)).unwrap_err().to_string();
            assert!(
                e.contains("test.toml: `axes`")
                    && e.contains(&format!("{runs} runs"))
                    && e.contains(&format!("a0 ({n} values)"))
                    && e.contains("a study holds at most 10000"),
                "{e}"
            );
        }
        assert_eq!(parse(&study(2, 100)).unwrap().runs.len(), 10_000);
    }

    #[test]
    fn run_directories_that_would_collide_are_refused_naming_both_runs() {
        let text = r#"
case = "hertz_2d.toml"
[[axes]]
name = "x"
keys = ["meshes.disk.n_arc"]
values = ["a_b", "a"]
[[axes]]
name = "y"
keys = ["meshes.disk.n_radial"]
values = ["c", "b_c"]
"#;
        let e = parse(text).unwrap_err().to_string();
        assert!(
            e.contains("`axes`")
                && e.contains("`a_b` + `c` (axes.0.values.0, axes.1.values.0)")
                && e.contains("`a` + `b_c` (axes.0.values.1, axes.1.values.1)")
                && e.contains("`a_b_c`"),
            "{e}"
        );
        let e = parse(
            &text
                .replace("\"a\"]", "\"A\"]")
                .replace("\"b_c\"", "\"B_c\""),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("letter case"), "{e}");
        let e = parse(&BASE.replace("\"fine\"", "\"logs\"").replace(
            "[[axes]]\nname = \"family\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1N2\", \"Q1C1\"]\n",
            "",
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("the study's own `logs`"), "{e}");
    }
}
