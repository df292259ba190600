//! Metrics of one run, computed from the columns of its `history.csv` (see the module doc of
//! [`crate::study`] for the definitions).

use serde::Deserialize;
use std::path::Path;

/// What a metric computes from the window's values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MetricKind {
    /// Largest minus smallest value over all columns together (eq. 22 of the paper).
    Range,
    /// Largest over the columns of each column's largest minus smallest value (eq. 23).
    RangeEce,
    /// Mean of the row-wise mean of the columns.
    Mean,
    /// Sum of the row-wise mean of the columns.
    Sum,
    /// The row-wise mean of the columns at the window's last row.
    Last,
    /// Largest value over all columns.
    Max,
    /// Smallest value over all columns.
    Min,
    /// Largest absolute value over all columns.
    MaxAbs,
    /// Smallest slope between consecutive rows, d(column)/d(x), over all columns.
    MinSlope,
    /// Largest over the columns of the peak-to-peak amplitude of what is left of the column after
    /// removing its least-squares polynomial trend in x of degree `detrend`.
    Oscillation,
    /// Largest value of the results.h5 field `field` at the last written step, on the first of
    /// `grids` that has it (not from history.csv).
    FieldMax,
    /// Hertz's peak pressure p0 for the load of `column` at the window's last row (`hertz`).
    HertzP0,
}

/// `hertz = { shape = "sphere", radius = 1.0, E = 1.0, nu = 0.3, load_scale = 4.0 }`: the
/// classical contact of an elastic sphere (or, per unit length in plane strain, a cylinder) of
/// `radius` on a rigid flat, for the load `load_scale` times the metric's column (e.g. 4 for a
/// quarter model, -1 for a reaction). With E* = E / (1 - nu^2): sphere a = (3 P R / (4 E*))^(1/3),
/// p0 = 3 P / (2 pi a^2); cylinder a = (4 P R / (pi E*))^(1/2), p0 = 2 P / (pi a).
#[allow(non_snake_case)]
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HertzSpec {
    pub shape: HertzShape,
    pub radius: f64,
    pub E: f64,
    pub nu: f64,
    #[serde(default)]
    pub load_scale: Option<f64>,
}

/// The body of [`HertzSpec`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HertzShape {
    Sphere,
    Cylinder,
}

impl HertzSpec {
    /// Hertz's peak pressure for the load `p` (before `load_scale`).
    pub fn p0(&self, p: f64) -> Result<f64, String> {
        let p = p * self.load_scale.unwrap_or(1.0);
        if !(p > 0.0 && p.is_finite()) {
            return Err(format!(
                "Hertz's p0 needs a positive load, got {p} (after load_scale)"
            ));
        }
        let e_star = self.E / (1.0 - self.nu * self.nu);
        let pi = std::f64::consts::PI;
        Ok(match self.shape {
            HertzShape::Sphere => {
                let a = (3.0 * p * self.radius / (4.0 * e_star)).cbrt();
                3.0 * p / (2.0 * pi * a * a)
            }
            HertzShape::Cylinder => {
                let a = (4.0 * p * self.radius / (pi * e_star)).sqrt();
                2.0 * p / (pi * a)
            }
        })
    }
}

/// A metric as declared in the study file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricSpec {
    pub name: String,
    pub kind: MetricKind,
    /// One `history.csv` column (a leading `-` negates it) ...
    #[serde(default)]
    pub column: Option<String>,
    /// ... or several.
    #[serde(default)]
    pub columns: Vec<String>,
    /// The rows used: those whose `column` lies in `[min, max]`. Default: all rows.
    #[serde(default)]
    pub window: Option<Window>,
    /// Abscissa of `min_slope` and `oscillation`. Default: the window's column, else `load_factor`.
    #[serde(default)]
    pub x: Option<String>,
    /// Degree of the trend removed by `oscillation`. Default 1 (a straight line).
    #[serde(default)]
    pub detrend: Option<usize>,
    /// Factor applied to the value (e.g. 1 / (E L0^2) to normalise). Default 1.
    #[serde(default)]
    pub scale: Option<f64>,
    /// Another metric of the same run that this one is divided by (which must not itself be relative).
    #[serde(default)]
    pub relative_to: Option<String>,
    /// `field_max`: the results.h5 field, e.g. `contact_pressure_nominal`.
    #[serde(default)]
    pub field: Option<String>,
    /// `field_max`: the grids tried in order (default `["surface", "bulk"]`: an enriched
    /// surface's sampled grid where there is one, else the mesh nodes).
    #[serde(default)]
    pub grids: Vec<String>,
    /// `hertz_p0`: the classical solution.
    #[serde(default)]
    pub hertz: Option<HertzSpec>,
}

/// `window = { column = "load_factor", min = 1.25, max = 2.0 }`; both bounds optional, inclusive.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Window {
    pub column: String,
    #[serde(default)]
    pub min: Option<f64>,
    #[serde(default)]
    pub max: Option<f64>,
}

impl MetricKind {
    /// The name used in study files.
    pub fn label(self) -> &'static str {
        match self {
            MetricKind::Range => "range",
            MetricKind::RangeEce => "range_ece",
            MetricKind::Mean => "mean",
            MetricKind::Sum => "sum",
            MetricKind::Last => "last",
            MetricKind::Max => "max",
            MetricKind::Min => "min",
            MetricKind::MaxAbs => "max_abs",
            MetricKind::MinSlope => "min_slope",
            MetricKind::Oscillation => "oscillation",
            MetricKind::FieldMax => "field_max",
            MetricKind::HertzP0 => "hertz_p0",
        }
    }
}

impl MetricSpec {
    /// The columns, from `column` or `columns`.
    pub fn column_list(&self) -> Vec<&str> {
        match &self.column {
            Some(c) => vec![c.as_str()],
            None => self.columns.iter().map(String::as_str).collect(),
        }
    }

    fn x_column(&self) -> &str {
        self.x
            .as_deref()
            .or(self.window.as_ref().map(|w| w.column.as_str()))
            .unwrap_or("load_factor")
    }
}

/// Checks the metric declarations: `(key, message)` of the first problem.
pub fn validate(metrics: &[MetricSpec]) -> Result<(), (String, String)> {
    for (i, m) in metrics.iter().enumerate() {
        let key = format!("metrics.{i}");
        if m.name.is_empty() || m.name.contains(',') || m.name.contains('"') {
            return Err((
                format!("{key}.name"),
                format!(
                    "`{}`: a metric needs a name without commas and quotes",
                    m.name
                ),
            ));
        }
        if metrics[..i].iter().any(|o| o.name == m.name) {
            return Err((
                format!("{key}.name"),
                format!("metric `{}` is declared twice", m.name),
            ));
        }
        let fields_only = |what: &str| format!("only `kind = \"{what}\"` reads it");
        if m.field.is_some() != (m.kind == MetricKind::FieldMax) {
            return Err((
                format!("{key}.field"),
                match m.kind {
                    MetricKind::FieldMax => {
                        format!("metric `{}` needs `field` (a results.h5 field)", m.name)
                    }
                    _ => fields_only("field_max"),
                },
            ));
        }
        if !m.grids.is_empty() && m.kind != MetricKind::FieldMax {
            return Err((format!("{key}.grids"), fields_only("field_max")));
        }
        if m.hertz.is_some() != (m.kind == MetricKind::HertzP0) {
            return Err((
                format!("{key}.hertz"),
                match m.kind {
                    MetricKind::HertzP0 => format!(
                        "metric `{}` needs `hertz = {{ shape, radius, E, nu }}`",
                        m.name
                    ),
                    _ => fields_only("hertz_p0"),
                },
            ));
        }
        if let Some(h) = &m.hertz {
            let bad = [("radius", h.radius), ("E", h.E)]
                .into_iter()
                .find(|(_, v)| !(v.is_finite() && *v > 0.0));
            if let Some((k, v)) = bad {
                return Err((
                    format!("{key}.hertz.{k}"),
                    format!("must be positive and finite, got {v}"),
                ));
            }
            if !(h.nu > -1.0 && h.nu < 0.5) {
                return Err((
                    format!("{key}.hertz.nu"),
                    format!("must be in (-1, 0.5), got {}", h.nu),
                ));
            }
            if m.column.is_none() {
                return Err((key, format!("metric `{}` needs `column`, the load", m.name)));
            }
        }
        if m.kind == MetricKind::FieldMax {
            if m.column.is_some() || !m.columns.is_empty() || m.window.is_some() {
                return Err((
                    key,
                    format!(
                        "metric `{}` reads results.h5 at the last step: no `column`, `columns` or `window`",
                        m.name
                    ),
                ));
            }
        } else {
            match (&m.column, m.columns.is_empty()) {
                (None, true) => {
                    return Err((
                        key,
                        format!("metric `{}` needs `column` or `columns`", m.name),
                    ))
                }
                (Some(_), false) => {
                    return Err((
                        key,
                        format!(
                            "metric `{}` has both `column` and `columns`; give one",
                            m.name
                        ),
                    ))
                }
                _ => {}
            }
            if m.column_list()
                .iter()
                .any(|c| c.trim_start_matches('-').is_empty())
            {
                return Err((key, format!("metric `{}` has an empty column name", m.name)));
            }
        }
        if let Some(w) = &m.window {
            if let (Some(a), Some(b)) = (w.min, w.max) {
                if a > b {
                    return Err((
                        format!("{key}.window"),
                        format!("min = {a} is above max = {b}"),
                    ));
                }
            }
        }
        if m.detrend.is_some() && m.kind != MetricKind::Oscillation {
            return Err((
                format!("{key}.detrend"),
                "only `kind = \"oscillation\"` removes a trend".into(),
            ));
        }
        if m.x.is_some() && !matches!(m.kind, MetricKind::MinSlope | MetricKind::Oscillation) {
            return Err((
                format!("{key}.x"),
                "only `min_slope` and `oscillation` use an abscissa".into(),
            ));
        }
        if let Some(s) = m.scale {
            if !s.is_finite() || s == 0.0 {
                return Err((
                    format!("{key}.scale"),
                    format!("must be finite and non-zero, got {s}"),
                ));
            }
        }
        if let Some(r) = &m.relative_to {
            match metrics.iter().find(|o| &o.name == r) {
                None => {
                    return Err((format!("{key}.relative_to"), format!("no metric `{r}`")));
                }
                Some(o) if o.name == m.name => {
                    return Err((
                        format!("{key}.relative_to"),
                        "a metric cannot be relative to itself".into(),
                    ));
                }
                Some(o) if o.relative_to.is_some() => {
                    return Err((
                        format!("{key}.relative_to"),
                        format!("`{r}` is itself relative to another metric"),
                    ));
                }
                Some(_) => {}
            }
        }
    }
    Ok(())
}

/// The columns of a `history.csv`.
#[derive(Debug, Clone, Default)]
pub struct Table {
    pub header: Vec<String>,
    /// `[column][row]`.
    pub cols: Vec<Vec<f64>>,
}

impl Table {
    /// Parses a `history.csv` text; `what` names it in messages.
    pub fn parse(text: &str, what: &str) -> Result<Table, String> {
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header: Vec<String> = lines
            .next()
            .ok_or_else(|| format!("{what}: empty file"))?
            .split(',')
            .map(|s| s.trim().to_string())
            .collect();
        let mut cols = vec![Vec::new(); header.len()];
        for (r, line) in lines.enumerate() {
            let cells: Vec<&str> = line.split(',').collect();
            if cells.len() != header.len() {
                return Err(format!(
                    "{what}: row {} has {} cells, the header {}",
                    r + 1,
                    cells.len(),
                    header.len()
                ));
            }
            for (c, cell) in cells.iter().enumerate() {
                cols[c].push(cell.trim().parse::<f64>().map_err(|_| {
                    format!(
                        "{what}: row {}, column `{}`: `{cell}` is not a number",
                        r + 1,
                        header[c]
                    )
                })?);
            }
        }
        Ok(Table { header, cols })
    }

    pub fn rows(&self) -> usize {
        self.cols.first().map_or(0, Vec::len)
    }

    /// A column by name; a leading `-` negates it.
    pub fn column(&self, name: &str) -> Result<Vec<f64>, String> {
        let (sign, bare) = match name.strip_prefix('-') {
            Some(b) => (-1.0, b),
            None => (1.0, name),
        };
        let i = self
            .header
            .iter()
            .position(|h| h == bare)
            .ok_or_else(|| format!("no column `{bare}` in history.csv"))?;
        Ok(self.cols[i].iter().map(|v| sign * v).collect())
    }
}

/// The largest value of `field` in `dir`/results.h5 at the last written step, on the first of
/// `grids` that has it.
pub fn field_max(dir: &Path, field: &str, grids: &[String]) -> Result<f64, String> {
    let path = dir.join("results.h5");
    let what = |e: hdf5::Error| format!("{}: {e}", path.display());
    let f = hdf5::File::open(&path).map_err(what)?;
    let steps = f.group("steps").map_err(what)?;
    let last = steps
        .member_names()
        .map_err(what)?
        .into_iter()
        .filter_map(|n| n.parse::<usize>().ok().map(|k| (k, n)))
        .max()
        .map(|(_, n)| n)
        .ok_or_else(|| format!("{}: no step written", path.display()))?;
    let defaults = ["surface".to_string(), "bulk".to_string()];
    let grids = if grids.is_empty() {
        &defaults[..]
    } else {
        grids
    };
    for g in grids {
        let name = format!("{last}/{g}/{field}");
        if steps.link_exists(&name) {
            let v = steps
                .dataset(&name)
                .and_then(|d| d.read_raw::<f64>())
                .map_err(what)?;
            return Ok(v.into_iter().fold(f64::NEG_INFINITY, f64::max));
        }
    }
    Err(format!(
        "{}: no field `{field}` on the grids {} of step {last}",
        path.display(),
        grids.join(", ")
    ))
}

/// The raw value of a metric (its `scale` applied, `relative_to` not); `dir` is the run's
/// directory (for `field_max`).
pub fn compute(m: &MetricSpec, t: &Table, dir: &Path) -> Result<f64, String> {
    if m.kind == MetricKind::FieldMax {
        let field = m.field.as_deref().expect("validated");
        let v = field_max(dir, field, &m.grids).map_err(|e| format!("metric `{}`: {e}", m.name))?;
        return Ok(v * m.scale.unwrap_or(1.0));
    }
    let rows: Vec<usize> = match &m.window {
        None => (0..t.rows()).collect(),
        Some(w) => {
            let c = t.column(&w.column)?;
            let tol = |b: f64| 1e-9 * b.abs().max(1.0);
            (0..t.rows())
                .filter(|&i| {
                    w.min.is_none_or(|a| c[i] >= a - tol(a))
                        && w.max.is_none_or(|b| c[i] <= b + tol(b))
                })
                .collect()
        }
    };
    if rows.is_empty() {
        return Err(format!(
            "metric `{}`: no row of history.csv in its window",
            m.name
        ));
    }
    let series: Vec<Vec<f64>> = m
        .column_list()
        .iter()
        .map(|c| t.column(c).map(|v| rows.iter().map(|&i| v[i]).collect()))
        .collect::<Result<_, _>>()?;
    let x: Vec<f64> = if matches!(m.kind, MetricKind::MinSlope | MetricKind::Oscillation) {
        let xc = t.column(m.x_column())?;
        rows.iter().map(|&i| xc[i]).collect()
    } else {
        Vec::new()
    };
    let value = match &m.hertz {
        Some(h) => {
            let load = *series[0].last().expect("a row in the window");
            h.p0(load)
        }
        None => kind_value(m.kind, &series, &x, m.detrend.unwrap_or(1)),
    }
    .map_err(|e| format!("metric `{}`: {e}", m.name))?;
    Ok(value * m.scale.unwrap_or(1.0))
}

/// One metric kind over the window's values `series[column][row]`, abscissa `x[row]`.
pub fn kind_value(
    kind: MetricKind,
    series: &[Vec<f64>],
    x: &[f64],
    detrend: usize,
) -> Result<f64, String> {
    let all = || series.iter().flatten().copied();
    let fold_max = |it: &mut dyn Iterator<Item = f64>| it.fold(f64::NEG_INFINITY, f64::max);
    let fold_min = |it: &mut dyn Iterator<Item = f64>| it.fold(f64::INFINITY, f64::min);
    let n = series.first().map_or(0, Vec::len);
    let row_mean = |i: usize| series.iter().map(|s| s[i]).sum::<f64>() / series.len() as f64;
    let range = |s: &[f64]| fold_max(&mut s.iter().copied()) - fold_min(&mut s.iter().copied());
    Ok(match kind {
        MetricKind::Range => fold_max(&mut all()) - fold_min(&mut all()),
        MetricKind::RangeEce => series
            .iter()
            .map(|s| range(s))
            .fold(f64::NEG_INFINITY, f64::max),
        MetricKind::Mean => (0..n).map(row_mean).sum::<f64>() / n as f64,
        MetricKind::Sum => (0..n).map(row_mean).sum::<f64>(),
        MetricKind::Last => row_mean(n - 1),
        MetricKind::Max => fold_max(&mut all()),
        MetricKind::Min => fold_min(&mut all()),
        MetricKind::MaxAbs => fold_max(&mut all().map(f64::abs)),
        MetricKind::MinSlope => {
            let mut best = f64::INFINITY;
            for s in series {
                for i in 1..n {
                    let dx = x[i] - x[i - 1];
                    if dx != 0.0 {
                        best = best.min((s[i] - s[i - 1]) / dx);
                    }
                }
            }
            if best == f64::INFINITY {
                return Err("needs two rows with different abscissae".into());
            }
            best
        }
        MetricKind::Oscillation => {
            if n < detrend + 2 {
                return Err(format!(
                    "{n} rows are too few to remove a trend of degree {detrend}"
                ));
            }
            let mut amp = f64::NEG_INFINITY;
            for s in series {
                let r = detrended(x, s, detrend)?;
                amp = amp.max(range(&r));
            }
            amp
        }
        MetricKind::FieldMax | MetricKind::HertzP0 => {
            return Err(format!(
                "`{}` is not computed from columns alone",
                kind.label()
            ))
        }
    })
}

/// `y` minus its least-squares polynomial of degree `deg` in `x` (x mapped to [-1, 1] first).
fn detrended(x: &[f64], y: &[f64], deg: usize) -> Result<Vec<f64>, String> {
    let (lo, hi) = (
        x.iter().copied().fold(f64::INFINITY, f64::min),
        x.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    if hi <= lo && deg > 0 {
        return Err("the abscissa is constant over the window".into());
    }
    let t: Vec<f64> = x
        .iter()
        .map(|&v| {
            if hi > lo {
                2.0 * (v - lo) / (hi - lo) - 1.0
            } else {
                0.0
            }
        })
        .collect();
    let a = nalgebra::DMatrix::from_fn(t.len(), deg + 1, |i, j| t[i].powi(j as i32));
    let b = nalgebra::DVector::from_column_slice(y);
    let coef = a
        .clone()
        .svd(true, true)
        .solve(&b, 1e-12)
        .map_err(|e| format!("trend fit failed: {e}"))?;
    let fit = a * coef;
    Ok(y.iter().zip(fit.iter()).map(|(v, f)| v - f).collect())
}

/// All metric values of a run: `Ok(value)` or the reason it could not be computed.
pub fn compute_all(metrics: &[MetricSpec], t: &Table, dir: &Path) -> Vec<Result<f64, String>> {
    let raw: Vec<Result<f64, String>> = metrics.iter().map(|m| compute(m, t, dir)).collect();
    metrics
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let v = raw[i].clone()?;
            match &m.relative_to {
                None => Ok(v),
                Some(r) => {
                    let j = metrics
                        .iter()
                        .position(|o| &o.name == r)
                        .expect("validated");
                    let d = raw[j].clone()?;
                    if d == 0.0 {
                        Err(format!("metric `{}`: `{r}` is zero", m.name))
                    } else {
                        Ok(v / d)
                    }
                }
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> Table {
        Table::parse(
            "step,load_factor,a,b\n1,0.5,1,-2\n2,1,3,-1\n3,1.5,2,-4\n4,2,5,-3\n",
            "t",
        )
        .unwrap()
    }

    fn metric(kind: MetricKind, cols: &[&str]) -> MetricSpec {
        MetricSpec {
            name: "m".into(),
            kind,
            column: None,
            columns: cols.iter().map(|c| c.to_string()).collect(),
            window: None,
            x: None,
            detrend: None,
            scale: None,
            relative_to: None,
            field: None,
            grids: Vec::new(),
            hertz: None,
        }
    }

    fn val(kind: MetricKind, cols: &[&str]) -> f64 {
        compute(&metric(kind, cols), &table(), Path::new(".")).unwrap()
    }

    #[test]
    fn each_kind_on_a_small_table() {
        use MetricKind::*;
        // a = [1, 3, 2, 5], -b = [2, 1, 4, 3]
        assert_eq!(val(Range, &["a", "-b"]), 5.0 - 1.0);
        assert_eq!(val(RangeEce, &["a", "-b"]), 4.0f64.max(3.0));
        assert_eq!(val(Range, &["a", "b"]), 5.0 - -4.0);
        assert_eq!(val(Mean, &["a"]), 11.0 / 4.0);
        assert_eq!(val(Mean, &["a", "b"]), (11.0 - 10.0) / 8.0);
        assert_eq!(val(Sum, &["a"]), 11.0);
        assert_eq!(val(Last, &["a", "-b"]), 4.0);
        assert_eq!(val(Max, &["a", "b"]), 5.0);
        assert_eq!(val(Min, &["a", "b"]), -4.0);
        assert_eq!(val(MaxAbs, &["b"]), 4.0);
        // slopes of a over load steps of 0.5: 4, -2, 6; of b: 2, -6, 2
        assert_eq!(val(MinSlope, &["a"]), -2.0);
        assert_eq!(val(MinSlope, &["a", "b"]), -6.0);
    }

    #[test]
    fn window_selects_rows_inclusively_with_tolerance() {
        let mut m = metric(MetricKind::Range, &["a"]);
        m.window = Some(Window {
            column: "load_factor".into(),
            min: Some(1.0 + 1e-12),
            max: None,
        });
        // rows 2..4: a = 3, 2, 5
        assert_eq!(compute(&m, &table(), Path::new(".")).unwrap(), 3.0);
        m.window.as_mut().unwrap().max = Some(1.5);
        assert_eq!(compute(&m, &table(), Path::new(".")).unwrap(), 1.0);
        m.window.as_mut().unwrap().min = Some(3.0);
        m.window.as_mut().unwrap().max = None;
        let e = compute(&m, &table(), Path::new(".")).unwrap_err();
        assert!(e.contains("no row"), "{e}");
    }

    #[test]
    fn oscillation_removes_the_trend() {
        // y = 2 + 3 x + 0.1 (-1)^i: a line plus an alternation of peak-to-peak 0.2
        let x: Vec<f64> = (0..9).map(|i| i as f64 * 0.25).collect();
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, &v)| 2.0 + 3.0 * v + if i % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        let amp = kind_value(MetricKind::Oscillation, std::slice::from_ref(&y), &x, 1).unwrap();
        // the alternation is not exactly orthogonal to a line over 9 points: the fit absorbs a bit
        let exact = {
            let r = detrended(&x, &y, 1).unwrap();
            r.iter().copied().fold(f64::MIN, f64::max) - r.iter().copied().fold(f64::MAX, f64::min)
        };
        assert_eq!(amp, exact);
        assert!((amp - 0.2).abs() < 0.03, "{amp}");
        // without detrending the line dominates
        let raw = kind_value(MetricKind::Oscillation, std::slice::from_ref(&y), &x, 0).unwrap();
        // max 2 + 6 + 0.1 (last point), min 2 + 0.1 (first point)
        assert!((raw - 6.0).abs() < 1e-12, "{raw}");
        // a pure quadratic is removed exactly by degree 2
        let q: Vec<f64> = x.iter().map(|v| 1.0 - v * v).collect();
        let amp2 = kind_value(MetricKind::Oscillation, &[q], &x, 2).unwrap();
        assert!(amp2 < 1e-12, "{amp2}");
    }

    #[test]
    fn relative_metrics_divide_by_their_reference() {
        let mut a = metric(MetricKind::Range, &["a"]);
        a.name = "ra".into();
        let mut b = metric(MetricKind::Mean, &["a"]);
        b.name = "mean".into();
        b.scale = Some(2.0);
        let mut c = metric(MetricKind::Range, &["a"]);
        c.name = "rel".into();
        c.relative_to = Some("mean".into());
        let v = compute_all(&[a, b, c], &table(), Path::new("."));
        assert_eq!(v[0], Ok(4.0));
        assert_eq!(v[1], Ok(5.5));
        assert_eq!(v[2], Ok(4.0 / 5.5));
    }

    #[test]
    fn bad_declarations_and_columns_are_named() {
        let mut a = metric(MetricKind::Range, &[]);
        assert!(validate(&[a.clone()])
            .unwrap_err()
            .1
            .contains("`column` or `columns`"));
        a.columns = vec!["a".into()];
        a.relative_to = Some("zz".into());
        assert_eq!(
            validate(&[a.clone()]).unwrap_err().0,
            "metrics.0.relative_to"
        );
        a.relative_to = None;
        a.detrend = Some(2);
        assert_eq!(validate(&[a.clone()]).unwrap_err().0, "metrics.0.detrend");
        let e = compute(
            &metric(MetricKind::Max, &["P_nope"]),
            &table(),
            Path::new("."),
        )
        .unwrap_err();
        assert!(e.contains("no column `P_nope`"), "{e}");
        let e = Table::parse("a,b\n1,x\n", "h.csv").unwrap_err();
        assert!(e.contains("h.csv") && e.contains("`x`"), "{e}");
    }

    #[test]
    #[allow(non_snake_case)]
    fn hertz_p0_follows_the_classical_formulas() {
        let pi = std::f64::consts::PI;
        let e_star = 1.0 / (1.0 - 0.09);
        let sphere = HertzSpec {
            shape: HertzShape::Sphere,
            radius: 2.0,
            E: 1.0,
            nu: 0.3,
            load_scale: Some(4.0),
        };
        // p0 = (6 P E*^2 / (pi^3 R^2))^(1/3) for the full load P = 4 x 3.8e-4
        let P = 4.0 * 3.8e-4;
        let want = (6.0 * P * e_star * e_star / (pi.powi(3) * 4.0)).cbrt();
        let got = sphere.p0(3.8e-4).unwrap();
        assert!((got - want).abs() < 1e-14 * want, "{got} vs {want}");
        // cylinder per unit length: p0 = (P E* / (pi R))^(1/2)
        let cyl = HertzSpec {
            shape: HertzShape::Cylinder,
            load_scale: None,
            ..sphere.clone()
        };
        let want = (8.5e-3 * e_star / (pi * 2.0)).sqrt();
        let got = cyl.p0(8.5e-3).unwrap();
        assert!((got - want).abs() < 1e-14 * want, "{got} vs {want}");
        assert!(sphere.p0(-1.0).unwrap_err().contains("positive load"));
    }

    #[test]
    fn field_max_reads_the_last_step_on_the_first_grid_that_has_the_field() {
        let dir = std::env::temp_dir().join(format!("field-max-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        {
            let f = hdf5::File::create(dir.join("results.h5")).unwrap();
            let put = |path: &str, v: &[f64]| {
                let g = f.create_group(path).unwrap();
                g.new_dataset_builder().with_data(v).create("p").unwrap();
            };
            // step names are zero-padded, as the results writer's
            put("steps/000002", &[]);
            put("steps/000002/surface", &[9.0]);
            put("steps/000010", &[]);
            put("steps/000010/bulk", &[3.0, 7.0, -1.0]);
        }
        // step 10 is the last (numerically), and it has no surface grid
        assert_eq!(field_max(&dir, "p", &[]).unwrap(), 7.0);
        let e = field_max(&dir, "q", &["surface".into()]).unwrap_err();
        assert!(e.contains("`q`") && e.contains("step 000010"), "{e}");
        let mut m = metric(MetricKind::FieldMax, &[]);
        m.field = Some("p".into());
        m.scale = Some(2.0);
        assert_eq!(compute(&m, &table(), &dir).unwrap(), 14.0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn field_and_hertz_metrics_are_validated() {
        let mut m = metric(MetricKind::FieldMax, &["a"]);
        m.field = Some("p".into());
        assert!(validate(&[m]).unwrap_err().1.contains("no `column`"));
        let m = metric(MetricKind::FieldMax, &[]);
        assert_eq!(validate(&[m]).unwrap_err().0, "metrics.0.field");
        let m = metric(MetricKind::HertzP0, &["a"]);
        assert_eq!(validate(&[m]).unwrap_err().0, "metrics.0.hertz");
        let mut m = metric(MetricKind::Max, &["a"]);
        m.grids = vec!["bulk".into()];
        assert_eq!(validate(&[m]).unwrap_err().0, "metrics.0.grids");
    }
}
