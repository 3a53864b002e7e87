//! Pure geometry of line charts, in data coordinates: decimation of long curves and
//! bands to a few points per pixel column (keeping their exact envelope), value ranges,
//! and the clipping of segments to the plot rectangle.

/// Columns of the x range within which consecutive points are merged: finer than the
/// PNG's pixels, so decimation is invisible.
pub(crate) const COLUMNS: f64 = 1600.0;
/// Lines and bands shorter than this are drawn as given.
pub(crate) const DECIMATE_ABOVE: usize = 4 * COLUMNS as usize;

pub(crate) fn column(x: f64, (x0, x1): (f64, f64)) -> i64 {
    ((x - x0) / (x1 - x0) * COLUMNS).floor() as i64
}

/// Keeps, of every run of consecutive points in one column, the first, lowest, highest
/// and last (in their order), so a long curve (e.g. one point per time step) keeps its
/// exact envelope with a few points per column.
pub(crate) fn decimate_line(line: Vec<(f64, f64)>, xr: (f64, f64)) -> Vec<(f64, f64)> {
    if line.len() <= DECIMATE_ABOVE {
        return line;
    }
    let mut out = Vec::new();
    let mut run: Vec<(usize, (f64, f64))> = Vec::new();
    let flush = |run: &mut Vec<(usize, (f64, f64))>, out: &mut Vec<(f64, f64)>| {
        if run.is_empty() {
            return;
        }
        let lo = run.iter().min_by(|a, b| a.1.1.total_cmp(&b.1.1)).expect("non-empty").0;
        let hi = run.iter().max_by(|a, b| a.1.1.total_cmp(&b.1.1)).expect("non-empty").0;
        let mut keep = vec![run[0].0, lo, hi, run[run.len() - 1].0];
        keep.sort_unstable();
        keep.dedup();
        let first = run[0].0;
        out.extend(keep.into_iter().map(|i| run[i - first].1));
        run.clear();
    };
    for (i, q) in line.into_iter().enumerate() {
        if run.last().is_some_and(|(_, r)| column(r.0, xr) != column(q.0, xr)) {
            flush(&mut run, &mut out);
        }
        run.push((i, q));
    }
    flush(&mut run, &mut out);
    out
}

/// Merges consecutive band points in one column into one: first x, lowest lower edge,
/// highest upper edge.
pub(crate) fn decimate_band(run: Vec<(f64, f64, f64)>, xr: (f64, f64)) -> Vec<(f64, f64, f64)> {
    if run.len() <= DECIMATE_ABOVE {
        return run;
    }
    let mut out: Vec<(f64, f64, f64)> = Vec::new();
    let mut last_col = None;
    for (x, l, h) in run {
        let c = column(x, xr);
        match out.last_mut() {
            Some(q) if last_col == Some(c) => {
                q.1 = q.1.min(l);
                q.2 = q.2.max(h);
            }
            _ => out.push((x, l, h)),
        }
        last_col = Some(c);
    }
    out
}

pub(crate) fn min_max(v: &[f64]) -> Option<(f64, f64)> {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (lo <= hi).then_some((lo, hi))
}

/// The part of segment a–b inside the rectangle (Liang–Barsky), if any.
pub(crate) fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, a.0 - x0), (dx, x1 - a.0), (-dy, a.1 - y0), (dy, y1 - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| {
        if t == 0.0 {
            a
        } else if t == 1.0 {
            b
        } else {
            (a.0 + t * dx, a.1 + t * dy)
        }
    };
    Some((at(t0), at(t1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_keeps_inside_parts() {
        let r = ((0.0, 1.0), (0.0, 1.0));
        assert_eq!(clip_segment((0.2, 0.2), (0.8, 0.8), r.0, r.1), Some(((0.2, 0.2), (0.8, 0.8))));
        assert_eq!(clip_segment((0.0, 0.5), (1.0, 1.5), r.0, r.1), Some(((0.0, 0.5), (0.5, 1.0))));
        assert_eq!(clip_segment((0.0, 2.0), (1.0, 2.0), r.0, r.1), None);
    }
}
