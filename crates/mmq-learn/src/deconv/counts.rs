//! Sparse lag co-occurrence counts C_j(i, i') = #{t : x_{t−j} = i, x_t = i'}: only the
//! (pair, pair, lag) triples that occurred are stored, as a sorted list of packed keys
//! and their counts. A step adds K + 1 keys to a pending buffer; before the counts are
//! read the buffer is sorted, run-length encoded and merged into the list. Memory is 12
//! bytes per distinct triple (at most (K + 1) per step, far fewer once the agent repeats
//! itself), independent of the number of pairs the world has; an index by pair (16 bytes
//! per pair and 4 per triple) lets a row of the Gram matrix read only its own triples.

use std::sync::Arc;

/// Bits of a packed key for the later pair and for the lag (the earlier pair takes the
/// rest): i · 2^(PAIR_BITS + LAG_BITS) + i' · 2^LAG_BITS + j.
const LAG_BITS: u32 = 17;
const PAIR_BITS: u32 = 23;

/// At most this many compact pairs.
pub(crate) const MAX_PAIRS: usize = 1 << PAIR_BITS;

/// At most this many pending keys before they are merged (bounds the buffer's memory).
const PENDING_MAX: usize = 1 << 22;

/// The packed key of (earlier pair `i`, later pair `i2`, lag `j`).
#[inline]
pub(crate) fn key(i: usize, i2: usize, j: usize) -> u64 {
    ((i as u64) << (PAIR_BITS + LAG_BITS)) | ((i2 as u64) << LAG_BITS) | j as u64
}

/// (earlier pair, later pair, lag) of a packed key.
#[inline]
pub(crate) fn unpack(k: u64) -> (usize, usize, usize) {
    (
        (k >> (PAIR_BITS + LAG_BITS)) as usize,
        ((k >> LAG_BITS) & ((1 << PAIR_BITS) - 1)) as usize,
        (k & ((1 << LAG_BITS) - 1)) as usize,
    )
}

/// The merged triples: their packed keys in key order and their counts, indexed by pair
/// both ways (the triples of an earlier pair are contiguous; those of a later pair are
/// listed by position), so that one row of the Gram matrix reads only its own triples.
#[derive(Clone, Debug, Default)]
pub(crate) struct Merged {
    keys: Vec<u64>,
    counts: Vec<u32>,
    /// The triples with earlier pair i are at fptr[i]..fptr[i + 1].
    fptr: Vec<usize>,
    /// The positions of the triples with later pair i, in key order, are
    /// tpos[tptr[i]..tptr[i + 1]].
    tptr: Vec<usize>,
    tpos: Vec<u32>,
}

impl Merged {
    /// The index of `keys` over `n` pairs (more when they hold more).
    fn new(keys: Vec<u64>, counts: Vec<u32>, n: usize) -> Self {
        let n = keys.iter().fold(n, |n, &k| {
            let (i, i2, _) = unpack(k);
            n.max(i + 1).max(i2 + 1)
        });
        let mut fptr = vec![0usize; n + 1];
        let mut tptr = vec![0usize; n + 1];
        for &k in &keys {
            let (i, i2, _) = unpack(k);
            fptr[i + 1] += 1;
            tptr[i2 + 1] += 1;
        }
        for i in 0..n {
            fptr[i + 1] += fptr[i];
            tptr[i + 1] += tptr[i];
        }
        let mut fill = tptr.clone();
        let mut tpos = vec![0u32; keys.len()];
        for (e, &k) in keys.iter().enumerate() {
            let i2 = unpack(k).1;
            tpos[fill[i2]] = e as u32;
            fill[i2] += 1;
        }
        Self { keys, counts, fptr, tptr, tpos }
    }

    /// The pairs indexed.
    pub(crate) fn n(&self) -> usize {
        self.fptr.len().saturating_sub(1)
    }

    /// The triples (earlier `i`, ·, ·), as (later pair, lag, count) in key order.
    pub(crate) fn triples_from(&self, i: usize) -> impl Iterator<Item = (usize, usize, u32)> + '_ {
        let (lo, hi) = (self.fptr[i], self.fptr[i + 1]);
        self.keys[lo..hi].iter().zip(&self.counts[lo..hi]).map(|(&k, &c)| {
            let (_, i2, j) = unpack(k);
            (i2, j, c)
        })
    }

    /// The triples (·, later `i2`, ·), as (earlier pair, lag, count) in key order.
    pub(crate) fn triples_to(&self, i2: usize) -> impl Iterator<Item = (usize, usize, u32)> + '_ {
        self.tpos[self.tptr[i2]..self.tptr[i2 + 1]].iter().map(|&e| {
            let (i, _, j) = unpack(self.keys[e as usize]);
            (i, j, self.counts[e as usize])
        })
    }

    /// The counts of (earlier `i`, later `i2`) by lag, as (lag, count) in lag order.
    pub(crate) fn pair_run(&self, i: usize, i2: usize) -> impl Iterator<Item = (usize, u32)> + '_ {
        let (lo, hi) = if i < self.n() { (self.fptr[i], self.fptr[i + 1]) } else { (0, 0) };
        let start = lo + self.keys[lo..hi].partition_point(|&k| k < key(i, i2, 0));
        let last = key(i, i2, (1 << LAG_BITS) - 1);
        self.keys[start..hi]
            .iter()
            .zip(&self.counts[start..hi])
            .take_while(move |(k, _)| **k <= last)
            .map(|(&k, &c)| (unpack(k).2, c))
    }

    /// Every triple, in key order, with its count.
    #[cfg(test)]
    pub(crate) fn iter(&self) -> impl Iterator<Item = (u64, u32)> + '_ {
        self.keys.iter().copied().zip(self.counts.iter().copied())
    }
}

/// The merged triples (shared with the Gram matrices read from them) and the keys not
/// merged yet.
#[derive(Clone, Debug, Default)]
pub(crate) struct CoCounts {
    merged: Arc<Merged>,
    pending: Vec<u64>,
}

impl CoCounts {
    /// One occurrence of (earlier pair `i`, later pair `i2`, lag `j`).
    #[inline]
    pub(crate) fn add(&mut self, i: usize, i2: usize, j: usize) {
        self.pending.push(key(i, i2, j));
        if self.pending.len() >= PENDING_MAX {
            self.merge(self.merged.n());
        }
    }

    /// Merges the pending keys into the sorted list and indexes it over `n` pairs (at
    /// least every pair in it; the counts do not depend on when).
    pub(crate) fn merge(&mut self, n: usize) {
        if self.pending.is_empty() && self.merged.n() == n {
            return;
        }
        let mut new = std::mem::take(&mut self.pending);
        new.sort_unstable();
        let old = std::mem::take(&mut self.merged);
        let (old_k, old_c) = (&old.keys, &old.counts);
        let mut keys = Vec::with_capacity(old_k.len() + new.len());
        let mut counts = Vec::with_capacity(old_k.len() + new.len());
        let (mut a, mut b) = (0, 0);
        while b < new.len() {
            // The next run of equal new keys; the old keys below it are copied as they are.
            let nk = new[b];
            let mut run = 0u32;
            while b < new.len() && new[b] == nk {
                run += 1;
                b += 1;
            }
            let below = a + gallop(&old_k[a..], nk);
            keys.extend_from_slice(&old_k[a..below]);
            counts.extend_from_slice(&old_c[a..below]);
            a = below;
            if a < old_k.len() && old_k[a] == nk {
                run += old_c[a];
                a += 1;
            }
            keys.push(nk);
            counts.push(run);
        }
        keys.extend_from_slice(&old_k[a..]);
        counts.extend_from_slice(&old_c[a..]);
        drop(old);
        keys.shrink_to_fit();
        counts.shrink_to_fit();
        self.merged = Arc::new(Merged::new(keys, counts, n));
        new.clear();
        self.pending = new;
    }

    /// The merged triples; pending keys are not included ([`Self::merge`] first).
    pub(crate) fn merged(&self) -> &Arc<Merged> {
        &self.merged
    }

    /// Distinct triples stored (merged).
    pub(crate) fn len(&self) -> usize {
        self.merged.keys.len()
    }

    /// Bytes held (merged, its index and pending, by capacity).
    pub(crate) fn bytes(&self) -> usize {
        let m = &self.merged;
        m.keys.capacity() * 8
            + m.counts.capacity() * 4
            + m.tpos.capacity() * 4
            + (m.fptr.capacity() + m.tptr.capacity()) * 8
            + self.pending.capacity() * 8
    }
}

/// The number of leading entries of the ascending `keys` below `k`, by galloping from the
/// front (O(log d) for an answer d: cheap when the next new key is near).
fn gallop(keys: &[u64], k: u64) -> usize {
    let mut hi = 1;
    while hi < keys.len() && keys[hi - 1] < k {
        hi *= 2;
    }
    let lo = hi / 2;
    let hi = hi.min(keys.len());
    lo + keys[lo..hi].partition_point(|&x| x < k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_pack_and_unpack() {
        for (i, i2, j) in [(0, 0, 0), (1, 2, 3), (MAX_PAIRS - 1, MAX_PAIRS - 1, 65_536), (5, 0, 1)] {
            assert_eq!(unpack(key(i, i2, j)), (i, i2, j));
        }
        // Key order is (earlier, later, lag) order.
        assert!(key(0, 5, 9) < key(1, 0, 0) && key(1, 0, 9) < key(1, 1, 0) && key(1, 1, 0) < key(1, 1, 1));
    }

    /// The galloping search agrees with a binary search.
    #[test]
    fn gallop_agrees_with_partition_point() {
        let mut rng = mmq_core::seed::rng_from_seed(3);
        use rand::RngExt;
        for (n, pairs) in [(10, 5), (5000, 40), (20_000, 9000)] {
            let mut keys: Vec<u64> = (0..n)
                .map(|_| key(rng.random_range(0..pairs), rng.random_range(0..pairs), rng.random_range(0..51)))
                .collect();
            keys.push(key(MAX_PAIRS - 1, MAX_PAIRS - 1, 65_536));
            keys.sort_unstable();
            let want = keys;
            for probe in [0, want[0], want[n / 2], want[n / 2] + 1, want[n], u64::MAX] {
                assert_eq!(gallop(&want, probe), want.partition_point(|&x| x < probe));
            }
        }
        assert_eq!(gallop(&[], 5), 0);
    }

    /// Counts merged in several batches equal counting them all at once; runs by lag.
    #[test]
    fn merges_add_up_counts() {
        let mut c = CoCounts::default();
        let adds = [(1, 2, 0), (1, 2, 3), (0, 0, 1), (1, 2, 0), (2, 1, 0)];
        for &(i, i2, j) in &adds[..3] {
            c.add(i, i2, j);
        }
        c.merge(3);
        for &(i, i2, j) in &adds[3..] {
            c.add(i, i2, j);
        }
        c.add(1, 2, 3);
        c.merge(3);
        c.merge(3);
        let m = c.merged();
        let all: Vec<_> = m.iter().map(|(k, n)| (unpack(k), n)).collect();
        assert_eq!(all, vec![((0, 0, 1), 1), ((1, 2, 0), 2), ((1, 2, 3), 2), ((2, 1, 0), 1)]);
        assert_eq!(m.pair_run(1, 2).collect::<Vec<_>>(), vec![(0, 2), (3, 2)]);
        assert_eq!(m.pair_run(2, 2).count(), 0);
        assert_eq!(c.len(), 4);
        // The index: triples by earlier pair, and by later pair in key order.
        assert_eq!(m.triples_from(1).collect::<Vec<_>>(), vec![(2, 0, 2), (2, 3, 2)]);
        assert_eq!(m.triples_from(0).collect::<Vec<_>>(), vec![(0, 1, 1)]);
        assert_eq!(m.triples_to(2).collect::<Vec<_>>(), vec![(1, 0, 2), (1, 3, 2)]);
        assert_eq!(m.triples_to(1).collect::<Vec<_>>(), vec![(2, 0, 1)]);
        assert_eq!(m.triples_to(0).collect::<Vec<_>>(), vec![(0, 1, 1)]);
    }
}
