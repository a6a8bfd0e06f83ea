//! The light grid's CPU twin: per-tile lists packed as the GPU packs them
//! (`shaders/common/light_grid_write.wgsl`), one `(first, count)` per list and one global
//! index buffer of `capacity` indices.
//!
//! 1. Lists are allocated one after another from a counter (on the GPU by atomic add, in
//!    any order; here in list order, so offsets differ but every total is the same).
//! 2. Once the counter has reached the capacity, a list is given `first = capacity` and
//!    stores nothing; the list that crosses the end keeps the indices that fit.
//! 3. `count` is always the true count; [`clip`] turns an entry into the stored range, as
//!    `light_list` does in WGSL, so a reader never goes out of bounds.
//!
//! Whatever the order, the stored pairs total `min(pairs, capacity)` and the dropped ones
//! `pairs - min(pairs, capacity)`: tests compare the GPU's header with these numbers.
//! Depends on nothing else in this crate.

/// Lists packed into one index buffer.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PackedGrid {
    /// Per list `(first, count)`: true count; the stored range is [`clip`]ped.
    pub entries: Vec<(u32, u32)>,
    /// The index buffer (`capacity` long; unused slots are 0).
    pub indices: Vec<u32>,
    /// Indices allocated (may pass the capacity).
    pub allocated: u64,
    /// (list, light) pairs.
    pub pairs: u64,
    /// Pairs that did not fit.
    pub dropped_pairs: u64,
    /// Lists that lost at least one light.
    pub dropped_lists: u32,
}

/// The stored part `(first, count)` of entry `(first, count)` in a buffer of `capacity`.
pub fn clip((first, count): (u32, u32), capacity: u32) -> (u32, u32) {
    let first = first.min(capacity);
    (first, count.min(capacity - first))
}

impl PackedGrid {
    /// Packs `lists` into a buffer of `capacity` indices.
    pub fn pack(lists: &[Vec<u32>], capacity: u32) -> Self {
        let mut g = PackedGrid { indices: vec![0; capacity as usize], ..Default::default() };
        for list in lists {
            let count = list.len() as u32;
            let mut first = capacity;
            if count > 0 {
                if g.allocated < capacity as u64 {
                    first = g.allocated as u32;
                    g.allocated += count as u64;
                }
                g.pairs += count as u64;
            }
            let (f, stored) = clip((first, count), capacity);
            g.indices[f as usize..(f + stored) as usize].copy_from_slice(&list[..stored as usize]);
            if stored < count {
                g.dropped_pairs += (count - stored) as u64;
                g.dropped_lists += 1;
            }
            g.entries.push((first, count));
        }
        g
    }

    /// The stored lights of list `l`.
    pub fn list(&self, l: usize) -> &[u32] {
        let (first, count) = clip(self.entries[l], self.indices.len() as u32);
        &self.indices[first as usize..(first + count) as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn lists_that_fit_are_stored_whole() {
        let lists = vec![vec![3, 1], vec![], vec![7, 8, 9]];
        let g = PackedGrid::pack(&lists, 5);
        assert_eq!(g.entries, vec![(0, 2), (5, 0), (2, 3)]);
        assert_eq!((g.list(0), g.list(1), g.list(2)), (&[3, 1][..], &[][..], &[7, 8, 9][..]));
        assert_eq!((g.pairs, g.dropped_pairs, g.dropped_lists), (5, 0, 0));
    }

    #[test]
    fn a_full_buffer_drops_what_does_not_fit_and_counts_it() {
        let lists = vec![vec![1, 2, 3], vec![4, 5, 6], vec![7]];
        let g = PackedGrid::pack(&lists, 4);
        assert_eq!(g.list(0), &[1, 2, 3]);
        assert_eq!(g.list(1), &[4]);
        assert_eq!(g.list(2), &[] as &[u32]);
        assert_eq!((g.pairs, g.dropped_pairs, g.dropped_lists), (7, 3, 2));
        // Entries keep the true count.
        assert_eq!(g.entries[1].1, 3);
    }

    proptest! {
        #![proptest_config(crate::test_seed::proptest_config(256))]

        /// Any lists, any capacity (down to 0): the stored ranges are disjoint, inside the
        /// buffer, prefixes of their lists, and total min(pairs, capacity).
        #[test]
        fn stored_ranges_are_disjoint_in_bounds_and_total_the_capacity(
            lists in proptest::collection::vec(proptest::collection::vec(0u32..1000, 0..40), 0..60),
            capacity in 0u32..600,
        ) {
            let g = PackedGrid::pack(&lists, capacity);
            let mut used = vec![false; capacity as usize];
            let mut stored = 0u64;
            for (l, list) in lists.iter().enumerate() {
                let (first, count) = clip(g.entries[l], capacity);
                prop_assert!(first as u64 + count as u64 <= capacity as u64);
                prop_assert_eq!(g.list(l), &list[..count as usize]);
                for slot in &mut used[first as usize..(first + count) as usize] {
                    prop_assert!(!*slot, "two lists share a slot");
                    *slot = true;
                }
                stored += count as u64;
            }
            let pairs: u64 = lists.iter().map(|l| l.len() as u64).sum();
            prop_assert_eq!(g.pairs, pairs);
            prop_assert_eq!(stored, pairs.min(capacity as u64));
            prop_assert_eq!(g.dropped_pairs, pairs - stored);
        }
    }
}
