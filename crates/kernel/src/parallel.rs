//! Deterministic data parallelism on the machine's cores: the work is cut into
//! chunks of a fixed size and the results are put back in input order, so the
//! output never depends on the number of threads or on their scheduling
//! (same input, same bytes out).

use std::sync::atomic::{AtomicUsize, Ordering};

/// Threads used: the machine's available parallelism, 1..=16.
pub fn threads() -> usize {
    std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, 16)
}

/// `f` of every `chunk`-sized slice of `items`, in order, computed on up to
/// [`threads`] scoped threads. A chunk whose thread panicked is computed again
/// on the caller's thread (so a panic surfaces there, where it can be caught).
pub fn map_chunks<T, R, F>(items: &[T], chunk: usize, f: F) -> Vec<R>
where
    T: Sync,
    R: Send,
    F: Fn(&[T]) -> R + Sync,
{
    let chunks: Vec<&[T]> = items.chunks(chunk.max(1)).collect();
    let workers = threads().min(chunks.len());
    if workers <= 1 {
        return chunks.into_iter().map(&f).collect();
    }
    let next = AtomicUsize::new(0);
    let mut parts: Vec<Option<R>> = (0..chunks.len()).map(|_| None).collect();
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                let (chunks, next, f) = (&chunks, &next, &f);
                scope.spawn(move || {
                    let mut done = Vec::new();
                    loop {
                        let c = next.fetch_add(1, Ordering::Relaxed);
                        let Some(items) = chunks.get(c) else { break };
                        done.push((c, f(items)));
                    }
                    done
                })
            })
            .collect();
        for h in handles {
            if let Ok(done) = h.join() {
                for (c, r) in done {
                    if let Some(slot) = parts.get_mut(c) {
                        *slot = Some(r);
                    }
                }
            }
        }
    });
    parts
        .into_iter()
        .zip(chunks)
        .map(|(r, items)| r.unwrap_or_else(|| f(items)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_back_in_input_order_for_any_chunk_size() {
        let items: Vec<u64> = (0..1000).collect();
        for chunk in [1, 7, 64, 1000, 5000] {
            let sums = map_chunks(&items, chunk, |c| c.iter().sum::<u64>());
            let expected: Vec<u64> = items.chunks(chunk).map(|c| c.iter().sum()).collect();
            assert_eq!(sums, expected, "chunk {chunk}");
        }
        assert!(map_chunks(&[] as &[u64], 8, |c| c.len()).is_empty());
    }
}
