//! Sparse lag co-occurrence counts C_j(i, i') = #{t : x_{t−j} = i, x_t = i'}: only the
//! (pair, pair, lag) triples that occurred are stored, as sorted packed keys and their
//! counts. A step adds K + 1 keys to a pending buffer; before the counts are read the
//! buffer is sorted (by radix), run-length encoded and merged in. The triples are kept
//! twice, each pair's own sorted run of them as earlier pair and as later pair, so that
//! one row of the Gram matrix reads its triples from two contiguous runs, and a merge
//! touches only the runs of pairs that have new co-occurrences: the counts of triples
//! already stored are added where they are, and new triples are merged into their run
//! from the back (moving only the part of that run after the first insertion). Memory is
//! 24 bytes per distinct triple (at most (K + 1) per step, far fewer once the agent
//! repeats itself), plus up to a quarter of that of each run's spare capacity, and about
//! 100 bytes per pair, independent of the number of pairs the world has.

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

/// The leading pair of a packed key.
#[inline]
fn lead(k: u64) -> usize {
    (k >> (PAIR_BITS + LAG_BITS)) as usize
}

/// One pair's triples in one order: their packed keys ascending and their counts.
#[derive(Clone, Debug, Default)]
struct Run {
    keys: Vec<u64>,
    counts: Vec<u32>,
}

impl Run {
    /// Adds the ascending distinct keys `new` (counts `new_c`), all of this run's leading
    /// pair: a key already here gets its count added in place, the others are inserted
    /// in order. Returns the number inserted; `missing` is scratch space.
    fn add(&mut self, new: &[u64], new_c: &[u32], missing: &mut Vec<(usize, u64, u32)>) -> usize {
        // The counts of the keys already here added (both ascend: a few old keys passed
        // one by one, a longer stretch by galloping); the others noted with the number
        // of old keys below them.
        missing.clear();
        let (keys, len) = (&self.keys, self.keys.len());
        let mut a = 0;
        for (&k, &c) in new.iter().zip(new_c) {
            let near = (a + 8).min(len);
            while a < near && keys[a] < k {
                a += 1;
            }
            if a == near {
                a += gallop(&keys[a..], k);
            }
            if a < len && keys[a] == k {
                self.counts[a] += c;
                a += 1;
            } else {
                missing.push((a, k, c));
            }
        }
        if missing.is_empty() {
            return 0;
        }
        let (old, total) = (len, len + missing.len());
        if self.keys.capacity() < total {
            // Into new arrays with room to grow by a quarter: each stretch of old keys
            // between two new ones copied once.
            let cap = total + total / 4;
            let (mut keys, mut counts) = (Vec::with_capacity(cap), Vec::with_capacity(cap));
            let mut a = 0;
            for &(p, k, c) in missing.iter() {
                if p - a < 8 {
                    for q in a..p {
                        keys.push(self.keys[q]);
                        counts.push(self.counts[q]);
                    }
                } else {
                    keys.extend_from_slice(&self.keys[a..p]);
                    counts.extend_from_slice(&self.counts[a..p]);
                }
                keys.push(k);
                counts.push(c);
                a = p;
            }
            keys.extend_from_slice(&self.keys[a..]);
            counts.extend_from_slice(&self.counts[a..]);
            (self.keys, self.counts) = (keys, counts);
            return missing.len();
        }
        // Else merged in from the back: each stretch of old keys above a new one is moved
        // once, by the number of new keys still to place below it.
        self.keys.resize(total, 0);
        self.counts.resize(total, 0);
        let mut a = old;
        for (m, &(p, k, c)) in missing.iter().enumerate().rev() {
            if a - p < 8 {
                for q in (p..a).rev() {
                    self.keys[q + m + 1] = self.keys[q];
                    self.counts[q + m + 1] = self.counts[q];
                }
            } else {
                self.keys.copy_within(p..a, p + m + 1);
                self.counts.copy_within(p..a, p + m + 1);
            }
            self.keys[p + m] = k;
            self.counts[p + m] = c;
            a = p;
        }
        missing.len()
    }

    fn bytes(&self) -> usize {
        self.keys.capacity() * 8 + self.counts.capacity() * 4 + std::mem::size_of::<Self>()
    }
}

/// The merged triples: for each pair, its triples as the earlier pair (keys
/// key(i, i2, j) in key order) and as the later pair (keys key(i2, i, j) of every
/// triple (i, i2, j), in that key order), so that one row of the Gram matrix reads only
/// its own triples.
#[derive(Clone, Debug, Default)]
pub(crate) struct Merged {
    /// The triples with earlier pair i.
    from: Vec<Run>,
    /// The triples with later pair i2, keyed by it.
    to: Vec<Run>,
    /// The triples (i, i, ·) are the `own[i].1` in `from[i]` from `own[i].0`.
    own: Vec<(u32, u32)>,
    /// Distinct triples.
    len: usize,
}

impl Merged {
    /// The pairs indexed.
    pub(crate) fn n(&self) -> usize {
        self.from.len()
    }

    /// The triples (earlier `i`, ·, ·), as (later pair, lag, count) in key order.
    pub(crate) fn triples_from(&self, i: usize) -> impl Iterator<Item = (usize, usize, u32)> + '_ {
        let r = &self.from[i];
        r.keys.iter().zip(&r.counts).map(|(&k, &c)| {
            let (_, i2, j) = unpack(k);
            (i2, j, c)
        })
    }

    /// The number of triples (earlier `i`, ·, ·).
    pub(crate) fn len_from(&self, i: usize) -> usize {
        self.from.get(i).map_or(0, |r| r.keys.len())
    }

    /// The triples (·, later `i2`, ·), as (earlier pair, lag, count) in key order.
    pub(crate) fn triples_to(&self, i2: usize) -> impl Iterator<Item = (usize, usize, u32)> + '_ {
        let r = &self.to[i2];
        r.keys.iter().zip(&r.counts).map(|(&k, &c)| {
            let (_, i, j) = unpack(k);
            (i, j, c)
        })
    }

    /// The counts of (earlier `i`, later `i2`) by lag, as (lag, count) in lag order.
    pub(crate) fn pair_run(&self, i: usize, i2: usize) -> impl Iterator<Item = (usize, u32)> + '_ {
        let (keys, counts): (&[u64], &[u32]) = self.from.get(i).map_or((&[], &[]), |r| (&r.keys, &r.counts));
        let start = keys.partition_point(|&k| k < key(i, i2, 0));
        let last = key(i, i2, (1 << LAG_BITS) - 1);
        keys[start..]
            .iter()
            .zip(&counts[start..])
            .take_while(move |(k, _)| **k <= last)
            .map(|(&k, &c)| (unpack(k).2, c))
    }

    /// The counts of (`i`, `i`) by lag, as (lag, count) in lag order: [`Self::pair_run`]
    /// of a pair with itself, found at the merge.
    pub(crate) fn own_run(&self, i: usize) -> impl Iterator<Item = (usize, u32)> + '_ {
        let (keys, counts, lo, len): (&[u64], &[u32], usize, usize) = match self.from.get(i) {
            Some(r) => (&r.keys, &r.counts, self.own[i].0 as usize, self.own[i].1 as usize),
            None => (&[], &[], 0, 0),
        };
        keys[lo..lo + len].iter().zip(&counts[lo..lo + len]).map(|(&k, &c)| (unpack(k).2, c))
    }

    /// Every triple, in key order, with its count.
    #[cfg(test)]
    pub(crate) fn iter(&self) -> impl Iterator<Item = (u64, u32)> + '_ {
        self.from.iter().flat_map(|r| r.keys.iter().copied().zip(r.counts.iter().copied()))
    }
}

/// Adds the ascending distinct keys `new` (counts `new_c`) to `runs`, the runs by each
/// key's leading pair. Returns the number of keys inserted; calls `touched` with each
/// leading pair whose run received keys.
fn add_by_lead(runs: &mut [Run], new: &[u64], new_c: &[u32], mut touched: impl FnMut(usize, &Run)) -> usize {
    let (mut inserted, mut missing) = (0, Vec::new());
    let mut s = 0;
    while s < new.len() {
        let i = lead(new[s]);
        let e = s + new[s..].partition_point(|&k| lead(k) == i);
        inserted += runs[i].add(&new[s..e], &new_c[s..e], &mut missing);
        touched(i, &runs[i]);
        s = e;
    }
    inserted
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

    /// Merges the pending keys into the sorted runs and indexes them over `n` pairs (at
    /// least every pair in them; the counts do not depend on when).
    pub(crate) fn merge(&mut self, n: usize) {
        if self.pending.is_empty() && self.merged.n() == n {
            return;
        }
        let mut new = std::mem::take(&mut self.pending);
        radix_sort(&mut new);
        // The distinct new keys and how often each came.
        let (mut fresh, mut runs) = (Vec::new(), Vec::new());
        for &k in &new {
            if fresh.last() == Some(&k) {
                *runs.last_mut().expect("a run per key") += 1;
            } else {
                fresh.push(k);
                runs.push(1u32);
            }
        }
        new.clear();
        self.pending = new;
        // Changed in place (copied only when a Gram matrix still reads them).
        let m = Arc::make_mut(&mut self.merged);
        let n = fresh.iter().fold(n.max(m.n()), |n, &k| {
            let (i, i2, _) = unpack(k);
            n.max(i + 1).max(i2 + 1)
        });
        m.from.resize_with(n, Run::default);
        m.to.resize_with(n, Run::default);
        m.own.resize(n, (0, 0));
        let own = &mut m.own;
        m.len += add_by_lead(&mut m.from, &fresh, &runs, |i, r| {
            let start = r.keys.partition_point(|&k| k < key(i, i, 0));
            let end = start + r.keys[start..].partition_point(|&k| k <= key(i, i, (1 << LAG_BITS) - 1));
            own[i] = (start as u32, (end - start) as u32);
        });
        // The new keys transposed, in their key order: a stable counting sort of the
        // key-ordered new keys by later pair.
        let mut at = vec![0usize; n + 1];
        for &k in &fresh {
            at[unpack(k).1 + 1] += 1;
        }
        for i in 0..n {
            at[i + 1] += at[i];
        }
        let (mut tfresh, mut truns) = (vec![0u64; fresh.len()], vec![0u32; fresh.len()]);
        for (&k, &c) in fresh.iter().zip(&runs) {
            let (i, i2, j) = unpack(k);
            tfresh[at[i2]] = key(i2, i, j);
            truns[at[i2]] = c;
            at[i2] += 1;
        }
        drop((fresh, runs));
        add_by_lead(&mut m.to, &tfresh, &truns, |_, _| {});
    }

    /// The merged triples; pending keys are not included ([`Self::merge`] first).
    pub(crate) fn merged(&self) -> &Arc<Merged> {
        &self.merged
    }

    /// Distinct triples stored (merged).
    pub(crate) fn len(&self) -> usize {
        self.merged.len
    }

    /// Bytes held (merged, both orders and their indexes, and pending, by capacity).
    pub(crate) fn bytes(&self) -> usize {
        let m = &self.merged;
        m.from.iter().chain(&m.to).map(Run::bytes).sum::<usize>()
            + (m.from.capacity() + m.to.capacity() - m.from.len() - m.to.len()) * std::mem::size_of::<Run>()
            + m.own.capacity() * 8
            + self.pending.capacity() * 8
    }
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
    let loose = |t: u64| {
        (t & ((1 << wl) - 1))
            | (((t >> wl) & ((1 << w2) - 1)) << LAG_BITS)
            | ((t >> (wl + w2)) << (LAG_BITS + PAIR_BITS))
    };
    let passes = total.div_ceil(12);
    let bits = total.div_ceil(passes);
    let (buckets, mask) = (1usize << bits, (1u64 << bits) - 1);
    // The keys packed tight and every digit's histogram, in one pass.
    let mut count = vec![0usize; passes as usize * buckets];
    for k in keys.iter_mut() {
        let t = tight(*k);
        *k = t;
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
        for &t in keys.iter() {
            let d = ((t >> shift) & mask) as usize;
            buf[count[d]] = t;
            count[d] += 1;
        }
        std::mem::swap(keys, &mut buf);
    }
    for k in keys.iter_mut() {
        *k = loose(*k);
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

    /// A run takes new keys into new arrays (no room) and in place (room left): counts
    /// of keys it holds added, the others inserted in order, at the front, between and
    /// at the back.
    #[test]
    fn runs_add_in_place_and_into_new_arrays() {
        let mut r = Run::default();
        let mut scratch = Vec::new();
        assert_eq!(r.add(&[10, 20, 30], &[1, 2, 3], &mut scratch), 3);
        r.keys.reserve(100);
        r.counts.reserve(100);
        assert_eq!(r.add(&[5, 20, 25, 40, 41], &[1, 1, 1, 1, 1], &mut scratch), 4);
        assert_eq!(r.keys, vec![5, 10, 20, 25, 30, 40, 41]);
        assert_eq!(r.counts, vec![1, 1, 3, 1, 3, 1, 1]);
        assert_eq!(r.add(&[10, 41], &[2, 2], &mut scratch), 0);
        assert_eq!(r.counts, vec![1, 3, 3, 1, 3, 1, 3]);
        let keys: Vec<u64> = (0..40).map(|k| 2 * k + 1).collect();
        let added = r.add(&keys, &[1; 40], &mut scratch);
        assert_eq!(added, 37);
        let mut want: Vec<u64> = keys.iter().copied().chain([10, 20, 30, 40]).collect();
        want.sort_unstable();
        assert_eq!(r.keys, want);
        assert_eq!(r.counts.iter().sum::<u32>(), 15 + 40);
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
    /// radix sort's cut-off.
    #[test]
    fn merged_orders_equal_a_plain_count() {
        let mut rng = mmq_core::seed::rng_from_seed(9);
        use rand::RngExt;
        let mut c = CoCounts::default();
        let mut all: std::collections::BTreeMap<u64, u32> = std::collections::BTreeMap::new();
        for (batch, pairs) in [(500, 8), (3000, 20), (10, 20), (0, 25), (6000, 60)] {
            for _ in 0..batch {
                let (i, i2, j) =
                    (rng.random_range(0..pairs), rng.random_range(0..pairs), rng.random_range(0..7));
                c.add(i, i2, j);
                *all.entry(key(i, i2, j)).or_default() += 1;
            }
            c.merge(pairs);
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
