//! Sparse lag co-occurrence counts C_j(i, i') = #{t : x_{t−j} = i, x_t = i'}: only the
//! (pair, pair, lag) triples that occurred are stored, as a sorted list of packed keys
//! and their counts. A step adds K + 1 keys to a pending buffer; before the counts are
//! read the buffer is sorted, run-length encoded and merged into the list. Memory is 12
//! bytes per distinct triple (at most (K + 1) per step, far fewer once the agent repeats
//! itself), independent of the number of pairs the world has.

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

/// The sorted triples and their counts, and the keys not merged yet.
#[derive(Clone, Debug, Default)]
pub(crate) struct CoCounts {
    keys: Vec<u64>,
    counts: Vec<u32>,
    pending: Vec<u64>,
}

impl CoCounts {
    /// One occurrence of (earlier pair `i`, later pair `i2`, lag `j`).
    #[inline]
    pub(crate) fn add(&mut self, i: usize, i2: usize, j: usize) {
        self.pending.push(key(i, i2, j));
        if self.pending.len() >= PENDING_MAX {
            self.merge();
        }
    }

    /// Merges the pending keys into the sorted list (the counts do not depend on when).
    pub(crate) fn merge(&mut self) {
        if self.pending.is_empty() {
            return;
        }
        let mut new = std::mem::take(&mut self.pending);
        new.sort_unstable();
        let (old_k, old_c) = (std::mem::take(&mut self.keys), std::mem::take(&mut self.counts));
        let mut keys = Vec::with_capacity(old_k.len() + new.len());
        let mut counts = Vec::with_capacity(old_k.len() + new.len());
        let (mut a, mut b) = (0, 0);
        while a < old_k.len() || b < new.len() {
            // The next run of equal new keys.
            let nk = new.get(b).copied().unwrap_or(u64::MAX);
            let ok = old_k.get(a).copied().unwrap_or(u64::MAX);
            if b < new.len() && (a == old_k.len() || nk <= ok) {
                let mut run = 0u32;
                while b < new.len() && new[b] == nk {
                    run += 1;
                    b += 1;
                }
                if a < old_k.len() && ok == nk {
                    run += old_c[a];
                    a += 1;
                }
                keys.push(nk);
                counts.push(run);
            } else {
                keys.push(ok);
                counts.push(old_c[a]);
                a += 1;
            }
        }
        keys.shrink_to_fit();
        counts.shrink_to_fit();
        self.keys = keys;
        self.counts = counts;
        new.clear();
        self.pending = new;
    }

    /// The merged triples, in key order (earlier pair, later pair, lag), with counts;
    /// pending keys are not included ([`Self::merge`] first).
    pub(crate) fn iter(&self) -> impl Iterator<Item = (u64, u32)> + '_ {
        self.keys.iter().copied().zip(self.counts.iter().copied())
    }

    /// The merged counts of (earlier `i`, later `i2`) by lag, as (lag, count) in lag order.
    pub(crate) fn pair_run(&self, i: usize, i2: usize) -> impl Iterator<Item = (usize, u32)> + '_ {
        let lo = self.keys.partition_point(|&k| k < key(i, i2, 0));
        let hi = key(i, i2, (1 << LAG_BITS) - 1);
        self.keys[lo..]
            .iter()
            .zip(&self.counts[lo..])
            .take_while(move |(k, _)| **k <= hi)
            .map(|(&k, &c)| (unpack(k).2, c))
    }

    /// Distinct triples stored (merged).
    pub(crate) fn len(&self) -> usize {
        self.keys.len()
    }

    /// Bytes held (merged and pending, by capacity).
    pub(crate) fn bytes(&self) -> usize {
        self.keys.capacity() * 8 + self.counts.capacity() * 4 + self.pending.capacity() * 8
    }
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

    /// Counts merged in several batches equal counting them all at once; runs by lag.
    #[test]
    fn merges_add_up_counts() {
        let mut c = CoCounts::default();
        let adds = [(1, 2, 0), (1, 2, 3), (0, 0, 1), (1, 2, 0), (2, 1, 0)];
        for &(i, i2, j) in &adds[..3] {
            c.add(i, i2, j);
        }
        c.merge();
        for &(i, i2, j) in &adds[3..] {
            c.add(i, i2, j);
        }
        c.add(1, 2, 3);
        c.merge();
        c.merge();
        let all: Vec<_> = c.iter().map(|(k, n)| (unpack(k), n)).collect();
        assert_eq!(all, vec![((0, 0, 1), 1), ((1, 2, 0), 2), ((1, 2, 3), 2), ((2, 1, 0), 1)]);
        assert_eq!(c.pair_run(1, 2).collect::<Vec<_>>(), vec![(0, 2), (3, 2)]);
        assert_eq!(c.pair_run(2, 2).count(), 0);
        assert_eq!(c.len(), 4);
    }
}
