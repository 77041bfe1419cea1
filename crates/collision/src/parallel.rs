//! A parallel map whose output does not depend on the thread count: work
//! items are taken one at a time by whichever thread is free, and each result
//! is put back at its item's index.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// `f` applied to each of `0..count`, in index order, on up to `threads`
/// threads (the machine's parallelism when 0).
pub fn map_indexed<T, F>(count: usize, threads: usize, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize) -> T + Sync,
{
    let threads = if threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        threads
    }
    .min(count.max(1));
    if threads <= 1 {
        return (0..count).map(f).collect();
    }
    let next = AtomicUsize::new(0);
    let slots: Vec<Mutex<Option<T>>> = (0..count).map(|_| Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= count {
                    break;
                }
                let value = f(i);
                *slots[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(value);
            });
        }
    });
    slots
        .into_iter()
        .map(|m| {
            m.into_inner()
                .unwrap_or_else(|e| e.into_inner())
                .expect("every index is mapped once")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn same_output_on_any_thread_count() {
        let one = super::map_indexed(1000, 1, |i| i * i % 97);
        let four = super::map_indexed(1000, 4, |i| i * i % 97);
        assert_eq!(one, four);
        assert_eq!(one[10], 100 % 97);
    }
}
