//! Grouping of a batch's queries by a small key (a material, a light, a lobe) so that each
//! group goes to its batched call: a stable counting sort into caller-owned buffers (heap
//! vectors in the renderer's queues, stack arrays in a composite's sample blocks). The
//! order within a group is the queries' order, so results do not depend on the grouping.

/// Groups the queries `0..n` by `key` (None: in no group) over `starts.len() - 1` keys,
/// stably: afterwards the queries of key k are `order[starts[k]..starts[k + 1]]`, in
/// increasing order. `order` holds at least as many entries as there are grouped queries.
pub fn group_stable(
    n: usize,
    key: impl Fn(usize) -> Option<usize>,
    starts: &mut [usize],
    order: &mut [u32],
) {
    let keys = starts.len() - 1;
    starts.fill(0);
    for i in 0..n {
        if let Some(k) = key(i) {
            debug_assert!(k < keys, "key {k} of {keys}");
            starts[k + 1] += 1;
        }
    }
    // One key takes every query (one material, one light, one lobe): the order is the
    // identity, written without the scatter's chain through the cursor.
    if let Some(k) = (0..keys).find(|&k| starts[k + 1] == n).filter(|_| n > 0) {
        for (i, o) in order[..n].iter_mut().enumerate() {
            *o = i as u32;
        }
        starts[..=k].fill(0);
        starts[k + 1..].fill(n);
        return;
    }
    for k in 1..=keys {
        starts[k] += starts[k - 1];
    }
    // starts[k] is key k's cursor: after the pass it is key k's end, the next key's start.
    for i in 0..n {
        if let Some(k) = key(i) {
            order[starts[k]] = i as u32;
            starts[k] += 1;
        }
    }
    for k in (1..=keys).rev() {
        starts[k] = starts[k - 1];
    }
    starts[0] = 0;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_are_stable_and_skip_unkeyed_queries() {
        let keys = [Some(2), None, Some(0), Some(2), Some(1), Some(0), None];
        let mut starts = [0usize; 4];
        let mut order = [u32::MAX; 7];
        group_stable(keys.len(), |i| keys[i], &mut starts, &mut order);
        assert_eq!(starts, [0, 2, 3, 5]);
        assert_eq!(&order[..5], &[2, 5, 4, 0, 3]);
        // One key takes every query: the identity.
        let one = [Some(1); 5];
        group_stable(one.len(), |i| one[i], &mut starts, &mut order);
        assert_eq!(starts, [0, 0, 5, 5]);
        assert_eq!(&order[..5], &[0, 1, 2, 3, 4]);
        // No queries: every group empty.
        group_stable(0, |i| keys[i], &mut starts, &mut order);
        assert_eq!(starts, [0; 4]);
    }
}
