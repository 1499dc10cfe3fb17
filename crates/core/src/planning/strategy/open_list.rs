//! The open list of the configuration-space search ([`super::cspace`]): a priority queue of grid
//! cells keyed by `(f, u32::MAX - g, cell)`, smallest first (lowest priority `f`, then the deeper
//! cell, then the lower cell index), popped in exactly the order of a binary heap of those keys.
//!
//! The priorities `f = g + w h` of a weighted A* over unit moves are small integers that change by
//! a few per move, so the queue keeps one heap per priority (a bucket) and a cursor at the lowest
//! non-empty one. Each bucket's heap holds only the cells of one priority: a small heap that stays
//! in cache, where one heap of every open cell (millions) misses it at every level. Each cell enters
//! the open list once, so no two keys are equal and the order of the pops is the heap's.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Cells keyed by `(f, u32::MAX - g, cell)`, popped smallest first (see the module docs).
#[derive(Default)]
pub(crate) struct OpenList {
    /// One heap per priority `f`, each of `(u32::MAX - g) << 32 | cell`.
    buckets: Vec<BinaryHeap<Reverse<u64>>>,
    /// No bucket below this one holds a cell.
    lowest: usize,
    len: usize,
}

impl OpenList {
    /// Add `cell` with priority `f` at depth `g`.
    pub(crate) fn push(&mut self, f: u32, g: u32, cell: u32) {
        let f = f as usize;
        if f >= self.buckets.len() {
            self.buckets.resize_with(f + 1, BinaryHeap::new);
        }
        self.buckets[f].push(Reverse((u64::from(u32::MAX - g) << 32) | u64::from(cell)));
        self.lowest = self.lowest.min(f);
        self.len += 1;
    }

    /// The cell of the smallest key with its depth `g`, removed; `None` when the list is empty.
    pub(crate) fn pop(&mut self) -> Option<(u32, u32)> {
        if self.len == 0 {
            return None;
        }
        while self.buckets[self.lowest].is_empty() {
            self.lowest += 1;
        }
        let Reverse(key) = self.buckets[self.lowest].pop()?;
        self.len -= 1;
        Some((u32::MAX - (key >> 32) as u32, key as u32))
    }

    /// Whether no cell is left.
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Pushes and pops interleaved as a weighted A* makes them (a pushed priority at most a few
    /// below the last popped one, depths growing by one a move, each cell once), against the binary
    /// heap of the same keys: the same cells in the same order, ties in `f` and `g` included.
    #[test]
    fn pops_in_the_order_of_a_binary_heap_of_the_same_keys() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for case in 0..50 {
            let mut open = OpenList::default();
            let mut heap: BinaryHeap<Reverse<(u32, u32, u32)>> = BinaryHeap::new();
            let mut next_cell = 0u32;
            let mut push = |open: &mut OpenList, heap: &mut BinaryHeap<_>, f: u32, g: u32| {
                // cells drawn out of order, so that index ties are broken by the index
                let cell = next_cell.wrapping_mul(2_654_435_761) % 8_388_608;
                next_cell += 1;
                open.push(f, g, cell);
                heap.push(Reverse((f, u32::MAX - g, cell)));
            };
            push(&mut open, &mut heap, 40 + case, 0);
            let mut popped = 0;
            while let Some(Reverse((f, deep, cell))) = heap.pop() {
                let g = u32::MAX - deep;
                assert_eq!(open.pop(), Some((g, cell)), "case {case}, pop {popped}");
                popped += 1;
                if popped < 3000 {
                    for _ in 0..rng.gen_range(0..4) {
                        // f' = g + 1 + w h' with h' >= h - 1: at least f - 1 for w = 2
                        let f1 = (f + rng.gen_range(0..6)).saturating_sub(1);
                        push(&mut open, &mut heap, f1, g + 1);
                    }
                }
            }
            assert!(open.is_empty() && open.pop().is_none());
        }
    }

    /// Priorities pushed in any order, far apart and below the cursor, still pop smallest first.
    #[test]
    fn pops_smallest_first_for_priorities_in_any_order() {
        let mut open = OpenList::default();
        for (f, g, cell) in [(9, 1, 5), (2, 3, 8), (2, 4, 9), (700, 0, 1), (2, 4, 3)] {
            open.push(f, g, cell);
        }
        assert_eq!(open.pop(), Some((4, 3)));
        open.push(1, 0, 2);
        let order: Vec<_> = std::iter::from_fn(|| open.pop()).collect();
        assert_eq!(order, vec![(0, 2), (4, 9), (3, 8), (1, 5), (0, 1)]);
    }
}
