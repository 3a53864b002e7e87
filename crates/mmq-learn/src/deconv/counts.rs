//! Sparse lag co-occurrence counts C_j(i, i') = #{t : x_{t−j} = i, x_t = i'}: only the
//! (pair, pair, lag) triples that occurred are stored, as a sorted list of packed keys
//! and their counts. A step adds K + 1 keys to a pending buffer; before the counts are
//! read the buffer is sorted (by radix), run-length encoded and merged into the list
//! (full chunks of it are sorted as they come on a spare core, when there is one).
//! The list is kept twice, ordered by earlier pair and by later pair, so that one row of
//! the Gram matrix reads its triples from two contiguous ranges. Memory is 24 bytes per
//! distinct triple (at most (K + 1) per step, far fewer once the agent repeats itself)
//! and 28 per pair, independent of the number of pairs the world has.

use std::sync::Arc;

use crate::spare::Later;

/// Bits of a packed key for the later pair and for the lag (the earlier pair takes the
/// rest): i · 2^(PAIR_BITS + LAG_BITS) + i' · 2^LAG_BITS + j.
const LAG_BITS: u32 = 17;
const PAIR_BITS: u32 = 23;

/// At most this many compact pairs.
pub(crate) const MAX_PAIRS: usize = 1 << PAIR_BITS;

/// At most this many keys added since the last merge (pending, or handed to a lent core
/// to sort) before they are merged (bounds their memory).
const PENDING_MAX: usize = 1 << 22;

/// Pending keys are handed to a lent core to sort in chunks of this many, when one is
/// free (a power of two that divides `PENDING_MAX`).
const CHUNK: usize = if cfg!(test) { 1 << 10 } else { 1 << 16 };

/// Distinct keys in ascending order and how often each came.
type Runs = (Vec<u64>, Vec<u32>);

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

/// The merged triples: their packed keys in key order and their counts, and the same
/// triples keyed (later pair, earlier pair, lag) in that key order, each indexed by its
/// leading pair (the triples of an earlier pair, and those of a later pair, are
/// contiguous), so that one row of the Gram matrix reads only its own triples.
#[derive(Clone, Debug, Default)]
pub(crate) struct Merged {
    keys: Vec<u64>,
    counts: Vec<u32>,
    /// The triples with earlier pair i are at `fptr[i]..fptr[i + 1]`.
    fptr: Vec<usize>,
    /// key(i2, i, j) of every triple (i, i2, j), in order, and its count.
    tkeys: Vec<u64>,
    tcounts: Vec<u32>,
    /// The triples with later pair i2 are at `tkeys[tptr[i2]..tptr[i2 + 1]]`.
    tptr: Vec<usize>,
    /// The triples (i, i, ·) are the `own_len[i]` from `keys[own[i]]`.
    own: Vec<usize>,
    own_len: Vec<u32>,
}

impl Merged {
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

    /// The number of triples (earlier `i`, ·, ·).
    pub(crate) fn len_from(&self, i: usize) -> usize {
        if i < self.n() { self.fptr[i + 1] - self.fptr[i] } else { 0 }
    }

    /// The triples (·, later `i2`, ·), as (earlier pair, lag, count) in key order.
    pub(crate) fn triples_to(&self, i2: usize) -> impl Iterator<Item = (usize, usize, u32)> + '_ {
        let (lo, hi) = (self.tptr[i2], self.tptr[i2 + 1]);
        self.tkeys[lo..hi].iter().zip(&self.tcounts[lo..hi]).map(|(&k, &c)| {
            let (_, i, j) = unpack(k);
            (i, j, c)
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

    /// The counts of (`i`, `i`) by lag, as (lag, count) in lag order: [`Self::pair_run`]
    /// of a pair with itself, found at the merge.
    pub(crate) fn own_run(&self, i: usize) -> impl Iterator<Item = (usize, u32)> + '_ {
        let (lo, len) = if i < self.n() { (self.own[i], self.own_len[i] as usize) } else { (0, 0) };
        self.keys[lo..lo + len].iter().zip(&self.counts[lo..lo + len]).map(|(&k, &c)| (unpack(k).2, c))
    }

    /// Every triple, in key order, with its count.
    #[cfg(test)]
    pub(crate) fn iter(&self) -> impl Iterator<Item = (u64, u32)> + '_ {
        self.keys.iter().copied().zip(self.counts.iter().copied())
    }
}

/// The merged triples (shared with the Gram matrices read from them) and the keys not
/// merged yet: pending, and chunks of them being sorted on a lent core.
///
/// Sorting the new keys is most of a merge's work on small worlds. When a core is free
/// (one seed of `mmq run` on two cores: [`crate::spare`]), each full chunk of pending
/// keys is sorted there while the learner goes on, and the merge combines the sorted
/// chunks with the rest. The counts are integers and the lists sorted, so they are the
/// same whichever keys were sorted where.
#[derive(Clone, Debug, Default)]
pub(crate) struct CoCounts {
    merged: Arc<Merged>,
    pending: Vec<u64>,
    sorting: Vec<Later<Runs>>,
    /// Keys in `sorting`.
    handed: usize,
}

impl CoCounts {
    /// One occurrence of (earlier pair `i`, later pair `i2`, lag `j`).
    #[inline]
    pub(crate) fn add(&mut self, i: usize, i2: usize, j: usize) {
        self.pending.push(key(i, i2, j));
        if self.pending.len() & (CHUNK - 1) == 0 {
            self.chunk_full();
        }
    }

    /// A chunk of pending keys is full: they are merged at `PENDING_MAX` keys since the
    /// last merge, else handed to a core to sort if one is free.
    #[cold]
    fn chunk_full(&mut self) {
        if self.pending.len() + self.handed >= PENDING_MAX {
            self.merge(self.merged.n());
            return;
        }
        let keys = std::mem::take(&mut self.pending);
        let n = keys.len();
        match crate::spare::lend(keys, |mut keys| sorted_runs(&mut keys)) {
            Ok(later) => {
                self.sorting.push(later);
                self.handed += n;
                self.pending.reserve(CHUNK);
            }
            Err(keys) => self.pending = keys,
        }
    }

    /// Whether [`Self::merge`] over `n` pairs has anything to do.
    pub(crate) fn merge_due(&self, n: usize) -> bool {
        !self.pending.is_empty() || !self.sorting.is_empty() || self.merged.n() != n
    }

    /// Merges the pending keys into the sorted lists and indexes them over `n` pairs (at
    /// least every pair in them; the counts do not depend on when).
    pub(crate) fn merge(&mut self, n: usize) {
        if !self.merge_due(n) {
            return;
        }
        let mut new = std::mem::take(&mut self.pending);
        // The distinct new keys and how often each came.
        let (mut fresh, mut runs) = sorted_runs(&mut new);
        for chunk in self.sorting.drain(..) {
            let (keys, counts) = chunk.wait();
            (fresh, runs) = merge_runs(fresh, runs, keys, counts, |_| {});
        }
        self.handed = 0;
        new.clear();
        self.pending = new;
        // The old lists are given up one order at a time (when no Gram matrix still reads
        // them), so that the merge holds at most one order twice.
        let old = std::mem::take(&mut self.merged);
        let mut old = Arc::try_unwrap(old).unwrap_or_else(|shared| (*shared).clone());
        let n = fresh.iter().fold(n.max(old.n()), |n, &k| {
            let (i, i2, _) = unpack(k);
            n.max(i + 1).max(i2 + 1)
        });
        // Triples not seen before, by earlier and by later pair.
        let (mut add_from, mut add_to) = (vec![0usize; n], vec![0usize; n]);
        let (old_keys, old_counts) = (std::mem::take(&mut old.keys), std::mem::take(&mut old.counts));
        let (old_tkeys, old_tcounts) = (std::mem::take(&mut old.tkeys), std::mem::take(&mut old.tcounts));
        let (tfresh, truns) = transposed(&fresh, &runs, n);
        // The two orders at once when a core is spare (both then held twice meanwhile),
        // else one after the other (at most one held twice).
        let ((keys, counts), (tkeys, tcounts)) = crate::spare::beside(
            || {
                merge_runs(old_keys, old_counts, &fresh, &runs, |k| {
                    let (i, i2, _) = unpack(k);
                    add_from[i] += 1;
                    add_to[i2] += 1;
                })
            },
            || merge_runs(old_tkeys, old_tcounts, &tfresh, &truns, |_| {}),
        );
        let fptr = grown_index(&old.fptr, &add_from);
        let tptr = grown_index(&old.tptr, &add_to);
        let mut m = Merged { keys, counts, fptr, tkeys, tcounts, tptr, own: Vec::new(), own_len: Vec::new() };
        for i in 0..n {
            let (lo, hi) = (m.fptr[i], m.fptr[i + 1]);
            let start = lo + m.keys[lo..hi].partition_point(|&k| k < key(i, i, 0));
            let end = start + m.keys[start..hi].partition_point(|&k| k <= key(i, i, (1 << LAG_BITS) - 1));
            m.own.push(start);
            m.own_len.push((end - start) as u32);
        }
        self.merged = Arc::new(m);
    }

    /// The merged triples; pending keys are not included ([`Self::merge`] first).
    pub(crate) fn merged(&self) -> &Arc<Merged> {
        &self.merged
    }

    /// Distinct triples stored (merged).
    pub(crate) fn len(&self) -> usize {
        self.merged.keys.len()
    }

    /// Bytes held (merged, both orders and their indexes, and pending, by capacity; not
    /// the chunks being sorted).
    pub(crate) fn bytes(&self) -> usize {
        let m = &self.merged;
        (m.keys.capacity() + m.tkeys.capacity()) * 8
            + (m.counts.capacity() + m.tcounts.capacity()) * 4
            + (m.fptr.capacity() + m.tptr.capacity() + m.own.capacity()) * 8
            + m.own_len.capacity() * 4
            + self.pending.capacity() * 8
    }
}

/// `keys` sorted, as distinct keys in ascending order with how often each came.
fn sorted_runs(keys: &mut Vec<u64>) -> Runs {
    radix_sort(keys);
    let (mut fresh, mut runs) = (Vec::new(), Vec::new());
    for &k in keys.iter() {
        if fresh.last() == Some(&k) {
            *runs.last_mut().expect("a run per key") += 1;
        } else {
            fresh.push(k);
            runs.push(1u32);
        }
    }
    (fresh, runs)
}

/// The ascending distinct keys `old` (counts `old_c`) with the ascending distinct keys
/// `new` (counts `new_c`) added: a key in both gets the sum of its counts. `inserted` is
/// told each key of `new` that was not in `old`.
fn merge_runs(
    old: Vec<u64>,
    old_c: Vec<u32>,
    new: &[u64],
    new_c: &[u32],
    mut inserted: impl FnMut(u64),
) -> (Vec<u64>, Vec<u32>) {
    let mut keys = Vec::with_capacity(old.len() + new.len());
    let mut counts = Vec::with_capacity(old.len() + new.len());
    let mut a = 0;
    for (&nk, &nc) in new.iter().zip(new_c) {
        // The old keys below the new one are copied as they are: a few one by one, a
        // longer stretch found by galloping and copied as a block.
        let near = (a + 8).min(old.len());
        while a < near && old[a] < nk {
            keys.push(old[a]);
            counts.push(old_c[a]);
            a += 1;
        }
        if a == near {
            let below = a + gallop(&old[a..], nk);
            keys.extend_from_slice(&old[a..below]);
            counts.extend_from_slice(&old_c[a..below]);
            a = below;
        }
        let mut run = nc;
        if a < old.len() && old[a] == nk {
            run += old_c[a];
            a += 1;
        } else {
            inserted(nk);
        }
        keys.push(nk);
        counts.push(run);
    }
    keys.extend_from_slice(&old[a..]);
    counts.extend_from_slice(&old_c[a..]);
    drop((old, old_c));
    keys.shrink_to_fit();
    counts.shrink_to_fit();
    (keys, counts)
}

/// The distinct key-ordered new keys `fresh` (with their counts `runs`) transposed to
/// (later pair, earlier pair, lag), in their key order: a stable counting sort by later
/// pair over `n` pairs.
fn transposed(fresh: &[u64], runs: &[u32], n: usize) -> (Vec<u64>, Vec<u32>) {
    let mut at = vec![0usize; n + 1];
    for &k in fresh {
        at[unpack(k).1 + 1] += 1;
    }
    for i in 0..n {
        at[i + 1] += at[i];
    }
    let (mut tfresh, mut truns) = (vec![0u64; fresh.len()], vec![0u32; fresh.len()]);
    for (&k, &c) in fresh.iter().zip(runs) {
        let (i, i2, j) = unpack(k);
        tfresh[at[i2]] = key(i2, i, j);
        truns[at[i2]] = c;
        at[i2] += 1;
    }
    (tfresh, truns)
}

/// The start of each pair's triples (and the end of the last) over `added.len()` pairs,
/// from those before (`old`, over at most as many pairs) and the number of triples
/// `added` to each pair.
fn grown_index(old: &[usize], added: &[usize]) -> Vec<usize> {
    let n = added.len();
    let mut ptr = Vec::with_capacity(n + 1);
    ptr.push(0);
    let mut acc = 0;
    for (i, &a) in added.iter().enumerate() {
        let had = if i + 1 < old.len() { old[i + 1] - old[i] } else { 0 };
        acc += had + a;
        ptr.push(acc);
    }
    ptr
}

/// Sorts packed keys ascending: least-significant-digit radix sort of the keys with their
/// three fields packed tight (only the bits any key sets, in the same order: the same
/// order of keys), in as few digits of at most 12 bits as cover them (a digit every key
/// shares is skipped); small buffers by comparison.
fn radix_sort(keys: &mut Vec<u64>) {
    if keys.len() < 1024 {
        keys.sort_unstable();
        return;
    }
    let or = keys.iter().fold(0u64, |a, &k| a | k);
    let width = |x: u64| 64 - x.leading_zeros();
    let wl = width(or & ((1 << LAG_BITS) - 1));
    let w2 = width((or >> LAG_BITS) & ((1 << PAIR_BITS) - 1));
    let w1 = width(or >> (LAG_BITS + PAIR_BITS));
    let total = wl + w2 + w1;
    if total == 0 {
        return;
    }
    let tight = |k: u64| {
        (k & ((1 << wl) - 1))
            | (((k >> LAG_BITS) & ((1 << w2) - 1)) << wl)
            | ((k >> (LAG_BITS + PAIR_BITS)) << (wl + w2))
    };
    let passes = total.div_ceil(12);
    let bits = total.div_ceil(passes);
    let (buckets, mask) = (1usize << bits, (1u64 << bits) - 1);
    // Every digit's histogram in one read.
    let mut count = vec![0usize; passes as usize * buckets];
    for &k in keys.iter() {
        let t = tight(k);
        for p in 0..passes {
            count[p as usize * buckets + ((t >> (p * bits)) & mask) as usize] += 1;
        }
    }
    let len = keys.len();
    let mut buf = vec![0u64; len];
    for (p, count) in count.chunks_exact_mut(buckets).enumerate() {
        if count.contains(&len) {
            continue;
        }
        let mut acc = 0;
        for c in count.iter_mut() {
            (*c, acc) = (acc, acc + *c);
        }
        let shift = p as u32 * bits;
        for &k in keys.iter() {
            let d = ((tight(k) >> shift) & mask) as usize;
            buf[count[d]] = k;
            count[d] += 1;
        }
        std::mem::swap(keys, &mut buf);
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
        assert_eq!(m.own_run(2).count(), 0);
        assert_eq!(m.own_run(0).collect::<Vec<_>>(), vec![(1, 1)]);
        assert_eq!(c.len(), 4);
        // The index: triples by earlier pair, and by later pair in key order.
        assert_eq!(m.triples_from(1).collect::<Vec<_>>(), vec![(2, 0, 2), (2, 3, 2)]);
        assert_eq!(m.triples_from(0).collect::<Vec<_>>(), vec![(0, 1, 1)]);
        assert_eq!(m.triples_to(2).collect::<Vec<_>>(), vec![(1, 0, 2), (1, 3, 2)]);
        assert_eq!(m.triples_to(1).collect::<Vec<_>>(), vec![(2, 0, 1)]);
        assert_eq!(m.triples_to(0).collect::<Vec<_>>(), vec![(0, 1, 1)]);
    }

    /// The radix sort agrees with a comparison sort, for keys of small and of large pair
    /// ids and lags, with repeats.
    #[test]
    fn radix_sort_agrees_with_sort_unstable() {
        let mut rng = mmq_core::seed::rng_from_seed(4);
        use rand::RngExt;
        for (n, pairs, lags) in [(10, 5, 3), (5000, 40, 51), (30_000, 9000, 51), (20_000, MAX_PAIRS, 1 << 17)]
        {
            let mut keys: Vec<u64> = (0..n)
                .map(|_| {
                    key(rng.random_range(0..pairs), rng.random_range(0..pairs), rng.random_range(0..lags))
                })
                .collect();
            keys.extend_from_within(..n / 3);
            let mut want = keys.clone();
            want.sort_unstable();
            radix_sort(&mut keys);
            assert_eq!(keys, want);
        }
    }

    /// Random batches merged one after another, the pairs growing: the triples in both
    /// orders and by pair equal a count of every key, batch sizes below and above the
    /// radix sort's cut-off and the chunk size; with everything on this thread, and with
    /// full chunks sorted and the order by later pair merged on a second.
    #[test]
    fn merged_orders_equal_a_plain_count() {
        for beside in [false, true] {
            crate::spare::FORCE.with(|f| f.set(Some(beside)));
            check_merged_orders(9);
            crate::spare::FORCE.with(|f| f.set(None));
        }
    }

    fn check_merged_orders(seed: u64) {
        let mut rng = mmq_core::seed::rng_from_seed(seed);
        use rand::RngExt;
        let mut c = CoCounts::default();
        let mut all: std::collections::BTreeMap<u64, u32> = std::collections::BTreeMap::new();
        for (batch, pairs) in [(500, 8), (3000, 20), (10, 20), (0, 25), (6000, 60), (2 * CHUNK, 60)] {
            for _ in 0..batch {
                let (i, i2, j) =
                    (rng.random_range(0..pairs), rng.random_range(0..pairs), rng.random_range(0..7));
                c.add(i, i2, j);
                *all.entry(key(i, i2, j)).or_default() += 1;
            }
            // Full chunks went to the lent core, when there is one.
            let lent = crate::spare::FORCE.with(std::cell::Cell::get) == Some(true);
            assert_eq!(c.sorting.len(), if lent { batch / CHUNK } else { 0 });
            c.merge(pairs);
            assert!(c.sorting.is_empty() && c.handed == 0);
            let m = c.merged();
            assert_eq!(m.n(), pairs);
            assert_eq!(m.iter().collect::<Vec<_>>(), all.iter().map(|(&k, &n)| (k, n)).collect::<Vec<_>>());
            for p in 0..pairs {
                let from: Vec<_> = all
                    .iter()
                    .filter(|(k, _)| unpack(**k).0 == p)
                    .map(|(&k, &n)| (unpack(k).1, unpack(k).2, n))
                    .collect();
                let to: Vec<_> = all
                    .iter()
                    .filter(|(k, _)| unpack(**k).1 == p)
                    .map(|(&k, &n)| (unpack(k).0, unpack(k).2, n))
                    .collect();
                assert_eq!(m.triples_from(p).collect::<Vec<_>>(), from);
                assert_eq!(m.triples_to(p).collect::<Vec<_>>(), to);
                assert_eq!(m.own_run(p).collect::<Vec<_>>(), m.pair_run(p, p).collect::<Vec<_>>());
            }
        }
    }
}
