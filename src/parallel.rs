//! Work spread over the CPU's threads with results in input order, so that what a step makes
//! does not depend on how many threads made it (the importers, the preparation and the BVH use
//! it for passes over millions of triangles, which one thread took seconds over).

/// The threads work may be spread over: the CPU's, or 1 where the count is unknown.
pub fn threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `f` of 0..count, in order, computed in chunks on the CPU's threads.
pub fn map_indices<T: Send + Default + Clone>(
    count: usize,
    f: impl Fn(usize) -> T + Sync,
) -> Vec<T> {
    const CHUNK: usize = 1 << 16;
    let mut out = vec![T::default(); count];
    if count <= CHUNK {
        out.iter_mut()
            .enumerate()
            .for_each(|(i, slot)| *slot = f(i));
        return out;
    }
    let chunks = std::sync::Mutex::new(out.chunks_mut(CHUNK).enumerate());
    std::thread::scope(|scope| {
        for _ in 0..threads().min(count.div_ceil(CHUNK)) {
            scope.spawn(|| loop {
                let Some((c, chunk)) = chunks.lock().expect("chunks").next() else {
                    return;
                };
                for (k, slot) in chunk.iter_mut().enumerate() {
                    *slot = f(c * CHUNK + k);
                }
            });
        }
    });
    out
}

/// `text` cut into about `count` pieces of whole lines (at least 64 KiB each), for threads that
/// read a text file's lines.
pub fn line_pieces(text: &str, count: usize) -> Vec<&str> {
    let mut pieces = Vec::new();
    let mut rest = text;
    let size = text.len().div_ceil(count.max(1)).max(1 << 16);
    while !rest.is_empty() {
        let end = match rest.len() > size {
            // after a newline byte: a character boundary
            true => (rest.as_bytes()[size..].iter())
                .position(|&b| b == b'\n')
                .map_or(rest.len(), |i| size + i + 1),
            false => rest.len(),
        };
        pieces.push(&rest[..end]);
        rest = &rest[end..];
    }
    pieces
}

#[cfg(test)]
mod tests {
    /// Every index is computed once, in its place, whatever the chunking.
    #[test]
    fn every_index_lands_in_its_place() {
        for count in [0, 1, 1000, (1 << 16) + 1, 300_000] {
            let out = super::map_indices(count, |i| i as u64 * 3 + 1);
            assert_eq!(out.len(), count);
            assert!(out.iter().enumerate().all(|(i, &v)| v == i as u64 * 3 + 1));
        }
    }
}
