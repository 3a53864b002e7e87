//! The Gram matrix G of the reward fit under one delay pmf, read from the sparse
//! co-occurrence counts a row at a time, when the fit first needs it.
//!
//! With w_0 = a_0 / 2, w_j = a_j (j ≥ 1) and H(i, i') = Σ_j w_j C_j(i, i') (summed in lag
//! order), G(i, i') = H(i, i') + H(i', i), less the edge terms of the last K steps
//! ([`super::stats::LagStats::gram`]). A coordinate-descent fit reads the diagonal and
//! the rows of the features that ever leave zero (and of the pairs that share a group
//! feature); in a large world those are a small part of all rows. Row i reads only the
//! triples with i as the earlier or as the later pair ([`super::counts::Merged`]), so a
//! fit costs what it reads, and every entry is the same number, bit for bit, as in the
//! whole matrix built at once.

use std::sync::Arc;
use std::sync::OnceLock;

use super::counts::Merged;

/// One edge term: G(v, w) −= deficit, and G(w, v) −= deficit when `lagged` (v and w
/// are the pairs of two different steps; else v = w, taken at the same step).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Edge {
    pub(crate) v: u32,
    pub(crate) w: u32,
    pub(crate) lagged: bool,
    pub(crate) deficit: f64,
}

/// One row: its non-zero columns in order and their values.
#[derive(Clone, Debug, Default, PartialEq)]
struct Row {
    col: Vec<u32>,
    val: Vec<f64>,
    /// The largest |entry| (set once the row is complete).
    max_abs: f64,
}

impl Row {
    /// row(c) −= v (an entry is made when there is none).
    fn sub(&mut self, c: u32, v: f64) {
        match self.col.binary_search(&c) {
            Ok(p) => self.val[p] -= v,
            Err(p) => {
                self.col.insert(p, c);
                self.val.insert(p, -v);
            }
        }
    }
}

/// The symmetric Gram matrix G over the compact pairs 0..n: its diagonal, and its rows
/// as they are first read.
#[derive(Clone, Debug)]
pub(crate) struct Gram {
    n: usize,
    diag: Vec<f64>,
    rows: Vec<OnceLock<Row>>,
    /// The counts and the lag weights w_j the rows are read from (none: every row given).
    source: Option<(Arc<Merged>, Vec<f64>)>,
    /// The edge terms by row, each row's in the order of the edges: row i subtracts
    /// `edge_terms[edge_at[i]..edge_at[i + 1]]`, as (column, deficit).
    edge_at: Vec<usize>,
    edge_terms: Vec<(u32, f64)>,
}

impl Gram {
    /// G over `n` pairs from the counts `merged`, the lag weights `w` and the edge terms,
    /// in the order they are subtracted.
    pub(crate) fn new(n: usize, merged: Arc<Merged>, w: Vec<f64>, edges: Vec<Edge>) -> Self {
        let mut diag: Vec<f64> = (0..n)
            .map(|i| {
                let mut h = 0.0;
                for (j, c) in merged.own_run(i) {
                    if w[j] != 0.0 {
                        h += w[j] * c as f64;
                    }
                }
                h + h
            })
            .collect();
        for e in &edges {
            if e.v == e.w {
                diag[e.v as usize] -= e.deficit;
                if e.lagged {
                    diag[e.v as usize] -= e.deficit;
                }
            }
        }
        // The terms of each edge in order, (row, column, deficit), then grouped by row
        // by a stable counting sort.
        let terms = edges.iter().flat_map(|e| {
            let back = e.lagged.then_some((e.w, e.v, e.deficit));
            std::iter::once((e.v, e.w, e.deficit)).chain(back)
        });
        let mut edge_at = vec![0usize; n + 1];
        for (row, _, _) in terms.clone() {
            edge_at[row as usize + 1] += 1;
        }
        for i in 0..n {
            edge_at[i + 1] += edge_at[i];
        }
        let mut next = edge_at.clone();
        let mut edge_terms = vec![(0u32, 0.0); edge_at[n]];
        for (row, col, deficit) in terms {
            edge_terms[next[row as usize]] = (col, deficit);
            next[row as usize] += 1;
        }
        Self { n, diag, rows: vec![OnceLock::new(); n], source: Some((merged, w)), edge_at, edge_terms }
    }

    /// An `n`×`n` matrix from its entries in row-major order (its non-zero entries kept).
    #[cfg(test)]
    pub(crate) fn from_dense(n: usize, g: Vec<f64>) -> Self {
        debug_assert_eq!(g.len(), n * n);
        let rows = (0..n)
            .map(|i| {
                let mut r = Row::default();
                for j in (0..n).filter(|&j| g[i * n + j] != 0.0) {
                    r.col.push(j as u32);
                    r.val.push(g[i * n + j]);
                }
                r.max_abs = r.val.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
                OnceLock::from(r)
            })
            .collect();
        let (edge_at, edge_terms) = (vec![0; n + 1], Vec::new());
        Self { n, diag: (0..n).map(|i| g[i * n + i]).collect(), rows, source: None, edge_at, edge_terms }
    }

    /// The number of rows (compact pairs).
    pub(crate) fn n(&self) -> usize {
        self.n
    }

    /// G(i, i).
    #[inline]
    pub(crate) fn diag(&self, i: usize) -> f64 {
        self.diag[i]
    }

    /// Row i, read from the counts the first time.
    fn row(&self, i: usize) -> &Row {
        self.rows[i].get_or_init(|| {
            let (merged, w) = self.source.as_ref().expect("rows given or read from counts");
            let forward = runs(merged.triples_from(i), w);
            let backward = runs(merged.triples_to(i), w);
            // G(i, c) = H(i, c) + H(c, i), merged in column order.
            let mut row = Row {
                col: Vec::with_capacity(forward.len().max(backward.len())),
                val: Vec::with_capacity(forward.len().max(backward.len())),
                max_abs: 0.0,
            };
            let (mut a, mut b) = (0, 0);
            while a < forward.len() || b < backward.len() {
                let ca = forward.get(a).map_or(u32::MAX, |x| x.0);
                let cb = backward.get(b).map_or(u32::MAX, |x| x.0);
                let (c, v) = if ca == cb {
                    a += 1;
                    b += 1;
                    (ca, forward[a - 1].1 + backward[b - 1].1)
                } else if ca < cb {
                    a += 1;
                    (ca, forward[a - 1].1)
                } else {
                    b += 1;
                    (cb, backward[b - 1].1)
                };
                row.col.push(c);
                row.val.push(v);
            }
            for &(c, deficit) in &self.edge_terms[self.edge_at[i]..self.edge_at[i + 1]] {
                row.sub(c, deficit);
            }
            row.max_abs = row.val.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
            row
        })
    }

    /// G(i, j).
    #[inline]
    pub(crate) fn get(&self, i: usize, j: usize) -> f64 {
        if i == j {
            return self.diag[i];
        }
        let r = self.row(i);
        r.col.binary_search(&(j as u32)).map_or(0.0, |p| r.val[p])
    }

    /// y += d · G(i, ·); returns max_c |G(i, c)|.
    #[inline]
    pub(crate) fn add_row(&self, i: usize, d: f64, y: &mut [f64]) -> f64 {
        let r = self.row(i);
        if r.col.len() == y.len() {
            // Every column present, in order: the same sums, without the indirection.
            for (yc, &v) in y.iter_mut().zip(&r.val) {
                *yc += v * d;
            }
        } else {
            for (&c, &v) in r.col.iter().zip(&r.val) {
                y[c as usize] += v * d;
            }
        }
        r.max_abs
    }

    /// G x for an `x` that is zero outside `support` (ascending): each entry
    /// Σ_j G(i, j) x(j) summed over j in `support` in order (the terms outside it are
    /// zeros; G is symmetric, so column j is row j).
    pub(crate) fn times_sparse(&self, support: &[usize], x: &[f64]) -> Vec<f64> {
        let mut y = vec![-0.0; self.n];
        for &j in support {
            let r = self.row(j);
            for (&c, &v) in r.col.iter().zip(&r.val) {
                y[c as usize] += v * x[j];
            }
        }
        y
    }

    /// Rows read so far.
    #[cfg(test)]
    pub(crate) fn rows_read(&self) -> usize {
        self.rows.iter().filter(|r| r.get().is_some()).count()
    }
}

/// H(i, ·) (or H(·, i)) from the triples of one pair in key order, (other pair, lag,
/// count): Σ_j w_j C_j per other pair, summed in lag order, as (other pair, value).
fn runs(triples: impl Iterator<Item = (usize, usize, u32)>, w: &[f64]) -> Vec<(u32, f64)> {
    let mut out: Vec<(u32, f64)> = Vec::new();
    let mut cur = usize::MAX;
    let mut acc = 0.0;
    for (other, j, c) in triples {
        if other != cur {
            if cur != usize::MAX {
                out.push((cur as u32, acc));
            }
            (cur, acc) = (other, 0.0);
        }
        if w[j] != 0.0 {
            acc += w[j] * c as f64;
        }
    }
    if cur != usize::MAX {
        out.push((cur as u32, acc));
    }
    out
}
