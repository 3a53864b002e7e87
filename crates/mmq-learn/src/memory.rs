//! One trajectory's memory, for parameter sharing: several agents (the robots of a swarm)
//! learn into one learner's tables, each with its own memory of its past steps.
//!
//! A learner's state splits in two: what it has learned (tables, counts, delay estimates),
//! which every trajectory updates, and its memory of the current trajectory (the last
//! steps it still has to credit, eligibility traces, a step waiting for its next action),
//! which belongs to one trajectory. [`crate::Learner::swap_memory`] exchanges the second
//! with a [`Memory`] held for another trajectory; a learner whose memory cannot be
//! separated from what it learned says so with [`crate::Learner::shares_tables`].
//!
//! [`MemorySlots`] is the bookkeeping a driver of several trajectories needs: one slot per
//! trajectory, the learner holding the memory of the one that acted last.

use std::any::Any;

/// A trajectory's memory while it is out of the learner: empty (a trajectory that has not
/// started, whose memory is the learner's fresh one) or what the learner swapped out.
#[derive(Default)]
pub struct Memory(Option<Box<dyn Any + Send>>);

impl std::fmt::Debug for Memory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() { "Memory(held)" } else { "Memory(empty)" })
    }
}

impl Memory {
    /// Whether no memory is held (a trajectory that has not started).
    pub fn is_empty(&self) -> bool {
        self.0.is_none()
    }

    /// Exchanges `current` (a learner's memory, of type `T`) with the one held here; an
    /// empty memory (or one of another type) comes in as `fresh()`. After the first
    /// exchange the box is reused: no allocation.
    pub fn swap_with<T: Any + Send>(&mut self, current: &mut T, fresh: impl FnOnce() -> T) {
        match self.0.as_mut().and_then(|b| b.downcast_mut::<T>()) {
            Some(held) => std::mem::swap(current, held),
            None => {
                let out = std::mem::replace(current, fresh());
                self.0 = Some(Box::new(out));
            }
        }
    }
}

/// The memories of `n` trajectories sharing one learner, which holds the memory of
/// `owner`; the others wait in their slots (`owner`'s slot holds a spare).
#[derive(Debug)]
pub struct MemorySlots {
    slots: Vec<Memory>,
    owner: usize,
}

impl MemorySlots {
    /// `n` trajectories; the learner holds trajectory 0's (fresh) memory.
    pub fn new(n: usize) -> Self {
        Self { slots: (0..n).map(|_| Memory::default()).collect(), owner: 0 }
    }

    /// Makes the learner hold trajectory `i`'s memory (nothing to do when it already
    /// does); `swap` is the learner's [`crate::Learner::swap_memory`].
    pub fn load(&mut self, i: usize, swap: impl FnOnce(&mut Memory)) {
        if i == self.owner {
            return;
        }
        // The learner takes i's memory and leaves the owner's in i's slot; the two slots
        // then trade, so the owner's memory waits in its own slot and i's holds the spare.
        swap(&mut self.slots[i]);
        self.slots.swap(i, self.owner);
        self.owner = i;
    }

    /// The trajectory whose memory the learner holds.
    pub fn owner(&self) -> usize {
        self.owner
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_memory_comes_in_fresh_and_takes_the_current_one() {
        let mut m = Memory::default();
        assert!(m.is_empty());
        let mut cur = vec![1, 2, 3];
        m.swap_with(&mut cur, Vec::new);
        assert_eq!(cur, Vec::<i32>::new());
        assert!(!m.is_empty());
        let mut other = vec![9];
        m.swap_with(&mut other, || vec![0]);
        assert_eq!(other, vec![1, 2, 3]);
        // A memory of another type is not taken for this one's.
        let mut s = String::from("x");
        m.swap_with(&mut s, || "fresh".to_string());
        assert_eq!(s, "fresh");
    }

    /// Three trajectories over a "learner" whose memory is a number: each trajectory gets
    /// back what it left, whatever the order of turns.
    #[test]
    fn slots_give_each_trajectory_back_its_own_memory() {
        let mut slots = MemorySlots::new(3);
        let mut held = 0u32; // trajectory 0's fresh memory
        let swap = |held: &mut u32, m: &mut Memory| m.swap_with(held, || 0);
        let turns = [0, 1, 1, 2, 0, 2, 1, 0, 0, 2];
        let mut expect = [0u32; 3];
        for (k, &i) in turns.iter().enumerate() {
            slots.load(i, |m| swap(&mut held, m));
            assert_eq!((slots.owner(), held), (i, expect[i]), "turn {k}");
            held += 10 + k as u32;
            expect[i] = held;
        }
    }
}
