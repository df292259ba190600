//! `study.csv` and `study.md` from the outcomes of a study's runs.

use crate::study::exec::{Outcome, Status};
use crate::study::metrics::{compute_all, Table};
use crate::study::spec::Study;

/// One run's line of the study: what `study.csv` holds.
#[derive(Debug, Clone)]
pub struct Row {
    pub run: String,
    pub labels: Vec<String>,
    pub converged: bool,
    /// No result yet (`--collect`: queued, running, never submitted); neither converged nor failed.
    pub missing: bool,
    pub skipped: bool,
    pub unknowns: Option<u64>,
    /// Converged load steps.
    pub steps: Option<usize>,
    /// Load factor of the last converged step.
    pub last_load: Option<f64>,
    pub newton_total: Option<u64>,
    pub newton_max: Option<u32>,
    pub cutbacks: Option<u64>,
    /// Seconds (summary.json `wall_time.total`).
    pub wall_time: Option<f64>,
    /// One per declared metric; `None` where it could not be computed (see `reason`).
    pub metrics: Vec<Option<f64>>,
    /// Why the run failed, or why some metric is missing.
    pub reason: String,
}

/// The rows of the study, in run order, with every metric computed from each converged run's
/// `history.csv`.
pub fn rows(study: &Study, outcomes: &[Outcome]) -> Vec<Row> {
    study
        .runs
        .iter()
        .zip(outcomes)
        .map(|(run, o)| {
            let s = o.summary.as_ref();
            let mut reasons = Vec::new();
            if let Status::Failed(r) | Status::Missing(r) = &o.status {
                reasons.push(r.clone());
            }
            let converged = o.status == Status::Converged;
            let metrics: Vec<Option<f64>> = match (&o.history, converged) {
                (Some(t), true) => compute_all(&study.spec.metrics, t, &o.dir)
                    .into_iter()
                    .map(|r| r.map_err(|e| reasons.push(e)).ok())
                    .collect(),
                (None, true) if !study.spec.metrics.is_empty() => {
                    reasons.push(format!("no readable history.csv in {}", o.dir.display()));
                    vec![None; study.spec.metrics.len()]
                }
                _ => vec![None; study.spec.metrics.len()],
            };
            let last_load = o
                .history
                .as_ref()
                .and_then(|t: &Table| t.column("load_factor").ok())
                .and_then(|c| c.last().copied())
                .or_else(|| s.and_then(|s| s.steps.last().map(|st| st.load)));
            Row {
                run: run.name.clone(),
                labels: run.labels.clone(),
                converged,
                missing: matches!(o.status, Status::Missing(_)),
                skipped: o.skipped,
                unknowns: s.map(|s| s.unknowns),
                steps: s.map(|s| s.newton.steps),
                last_load,
                newton_total: s.map(|s| s.newton.total_iterations),
                newton_max: s.map(|s| s.newton.max_iterations_per_step),
                cutbacks: s.map(|s| s.steps.iter().map(|st| u64::from(st.cutbacks)).sum()),
                wall_time: s.map(|s| s.wall_time.total),
                metrics,
                reason: reasons.join("; "),
            }
        })
        .collect()
}

impl Row {
    /// `converged`, `failed` or `missing` (no result yet).
    pub fn status(&self) -> &'static str {
        match (self.converged, self.missing) {
            (true, _) => "converged",
            (false, true) => "missing",
            (false, false) => "failed",
        }
    }
}

fn opt<T: ToString>(v: Option<T>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

fn csv_cell(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\"").replace(['\n', '\r'], " "))
    } else {
        s.to_string()
    }
}

/// The columns of `study.csv` before the metrics.
pub const CSV_FIXED: [&str; 9] = [
    "status",
    "skipped",
    "unknowns",
    "steps",
    "last_load",
    "newton_total",
    "newton_max_per_step",
    "cutbacks",
    "wall_time",
];

/// `study.csv`: `run`, the axes, the fixed columns, the metrics, `reason`.
pub fn csv(study: &Study, rows: &[Row]) -> String {
    let mut header = vec!["run".to_string()];
    header.extend(study.axis_names.iter().cloned());
    header.extend(CSV_FIXED.iter().map(|s| s.to_string()));
    header.extend(study.spec.metrics.iter().map(|m| m.name.clone()));
    header.push("reason".into());
    let mut out = header
        .iter()
        .map(|h| csv_cell(h))
        .collect::<Vec<_>>()
        .join(",")
        + "\n";
    for r in rows {
        let mut cells = vec![r.run.clone()];
        cells.extend(r.labels.iter().cloned());
        cells.extend([
            r.status().to_string(),
            u8::from(r.skipped).to_string(),
            opt(r.unknowns),
            opt(r.steps),
            opt(r.last_load),
            opt(r.newton_total),
            opt(r.newton_max),
            opt(r.cutbacks),
            opt(r.wall_time),
        ]);
        cells.extend(r.metrics.iter().map(|m| opt(*m)));
        cells.push(r.reason.clone());
        out += &(cells
            .iter()
            .map(|c| csv_cell(c))
            .collect::<Vec<_>>()
            .join(",")
            + "\n");
    }
    out
}

/// A number for tables: up to 5 decimals, scientific beyond 1e4 or below 1e-3.
pub fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-3 {
        format!("{v:.4e}")
    } else {
        format!("{:.5}", v)
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string()
    }
}

fn md_cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// `study.md`: the runs, then one table per metric (series as columns, the other axes as rows),
/// each value also in percent of the reference's.
pub fn markdown(study: &Study, rows: &[Row], command: &str) -> String {
    let mut md = format!("# Study `{}`\n\n", study.name);
    if !study.spec.description.is_empty() {
        md += &format!("{}\n\n", study.spec.description);
    }
    md += &format!(
        "Study file `{}`, base case `{}`; produced by `{command}`. Each run's results are in its \
         own directory beside this file; `study.csv` has every number of these tables at full \
         precision.\n\n",
        study.file.display(),
        study.case.display()
    );
    let conv = rows.iter().filter(|r| r.converged).count();
    let missing = rows.iter().filter(|r| r.missing).count();
    md += &format!(
        "{} runs: {} converged ({} of them finished by an earlier invocation), {} failed{}.\n\n",
        rows.len(),
        conv,
        rows.iter().filter(|r| r.converged && r.skipped).count(),
        rows.len() - conv - missing,
        if missing > 0 {
            format!(", {missing} without a result yet (queued, running or not submitted)")
        } else {
            String::new()
        }
    );
    // runs table
    md += "## Runs\n\n| run | status | unknowns | steps | Newton total | Newton max/step | cutbacks | wall time (s) |\n";
    md += "|---|---|---:|---:|---:|---:|---:|---:|\n";
    for r in rows {
        let status = if r.converged {
            "converged".to_string()
        } else if r.missing {
            format!("missing: {}", md_cell(&r.reason))
        } else {
            format!(
                "failed at load {}: {}",
                r.last_load.map_or("-".into(), fmt_num),
                md_cell(&r.reason)
            )
        };
        md += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.run,
            status,
            opt(r.unknowns),
            opt(r.steps),
            opt(r.newton_total),
            opt(r.newton_max),
            opt(r.cutbacks),
            r.wall_time.map_or(String::new(), |t| format!("{t:.2}"))
        );
    }
    md += "\n";
    let notes: Vec<&Row> = rows
        .iter()
        .filter(|r| r.converged && !r.reason.is_empty())
        .collect();
    if !notes.is_empty() {
        md += "Metrics missing:\n\n";
        for r in notes {
            md += &format!("- {}: {}\n", r.run, md_cell(&r.reason));
        }
        md += "\n";
    }

    // metric tables: rows = combinations of the non-series axes, columns = series values
    let series = study.series;
    let series_labels = crate::study::spec::axis_labels(&study.spec.axes[series]);
    let mut groups: Vec<Vec<String>> = Vec::new();
    for run in &study.runs {
        let key: Vec<String> = (0..run.labels.len())
            .filter(|&a| a != series)
            .map(|a| run.labels[a].clone())
            .collect();
        if !groups.contains(&key) {
            groups.push(key);
        }
    }
    let other_axes: Vec<&str> = (0..study.axis_names.len())
        .filter(|&a| a != series)
        .map(|a| study.axis_names[a].as_str())
        .collect();
    let find = |key: &[String], s: &str| -> Option<&Row> {
        study.runs.iter().zip(rows).find_map(|(run, row)| {
            let k: Vec<&String> = (0..run.labels.len())
                .filter(|&a| a != series)
                .map(|a| &run.labels[a])
                .collect();
            (k.iter()
                .map(|x| x.as_str())
                .eq(key.iter().map(String::as_str))
                && run.labels[series] == s)
                .then_some(row)
        })
    };
    let reference = study.spec.reference.as_deref();
    for (mi, m) in study.spec.metrics.iter().enumerate() {
        md += &format!(
            "## `{}`\n\n`{}` of {}{}{}{}",
            m.name,
            m.kind.label(),
            m.column_list()
                .iter()
                .map(|c| format!("`{c}`"))
                .collect::<Vec<_>>()
                .join(", "),
            m.window.as_ref().map_or(String::new(), |w| format!(
                " over {}{}{}",
                w.min.map_or(String::new(), |a| format!("{a} <= ")),
                w.column,
                w.max.map_or(String::new(), |b| format!(" <= {b}"))
            )),
            m.relative_to
                .as_ref()
                .map_or(String::new(), |r| format!(", divided by `{r}`")),
            match reference {
                Some(r) => format!(
                    "; in parentheses: percent of the `{}` = {r} value of the same row.\n\n",
                    study.axis_names[series]
                ),
                None => ".\n\n".into(),
            }
        );
        let head = if other_axes.is_empty() {
            "metric".to_string()
        } else {
            other_axes.join(" / ")
        };
        md += &format!("| {head} | {} |\n", series_labels.join(" | "));
        md += &format!("|---|{}\n", "---:|".repeat(series_labels.len()));
        for g in &groups {
            let ref_val = reference
                .and_then(|r| find(g, r))
                .and_then(|row| row.metrics[mi]);
            let cells: Vec<String> = series_labels
                .iter()
                .map(|s| match find(g, s).and_then(|row| row.metrics[mi]) {
                    None => "-".into(),
                    Some(v) => match ref_val {
                        Some(rv) if rv != 0.0 => {
                            format!("{} ({:.1} %)", fmt_num(v), 100.0 * v / rv)
                        }
                        _ => fmt_num(v),
                    },
                })
                .collect();
            let label = if g.is_empty() {
                m.name.clone()
            } else {
                g.join(" / ")
            };
            md += &format!("| {label} | {} |\n", cells.join(" | "));
        }
        md += "\n";
    }
    md
}
