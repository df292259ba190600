//! Metrics of one run, computed from the columns of its `history.csv` (see the module doc of
//! [`crate::study`] for the definitions).

use serde::Deserialize;

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

/// The raw value of a metric (its `scale` applied, `relative_to` not).
pub fn compute(m: &MetricSpec, t: &Table) -> Result<f64, String> {
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
    let value = kind_value(m.kind, &series, &x, m.detrend.unwrap_or(1))
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
pub fn compute_all(metrics: &[MetricSpec], t: &Table) -> Vec<Result<f64, String>> {
    let raw: Vec<Result<f64, String>> = metrics.iter().map(|m| compute(m, t)).collect();
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
        }
    }

    fn val(kind: MetricKind, cols: &[&str]) -> f64 {
        compute(&metric(kind, cols), &table()).unwrap()
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
        assert_eq!(compute(&m, &table()).unwrap(), 3.0);
        m.window.as_mut().unwrap().max = Some(1.5);
        assert_eq!(compute(&m, &table()).unwrap(), 1.0);
        m.window.as_mut().unwrap().min = Some(3.0);
        m.window.as_mut().unwrap().max = None;
        let e = compute(&m, &table()).unwrap_err();
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
        let v = compute_all(&[a, b, c], &table());
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
        let e = compute(&metric(MetricKind::Max, &["P_nope"]), &table()).unwrap_err();
        assert!(e.contains("no column `P_nope`"), "{e}");
        let e = Table::parse("a,b\n1,x\n", "h.csv").unwrap_err();
        assert!(e.contains("h.csv") && e.contains("`x`"), "{e}");
    }
}
