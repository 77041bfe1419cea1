//! A reader pair for `surface` and `pocket` that matches every reliable
//! publisher: ROS's default (volatile) and transient-local ones.
//!
//! A transient-local reader matches no volatile writer (DDS's durability
//! rule), and a volatile reader gets no history from a transient-local
//! writer that published before it matched. So the node reads each shape
//! topic twice, once volatile and once transient-local, and drops the
//! second copy of a sample both receive (same writer, same sequence number).

use futures::{Stream, StreamExt};
use ros2_client::{Gid, MessageInfo, ReadResult, Subscription};
use std::collections::{HashSet, VecDeque};

/// Samples remembered to drop the second copy; the two copies of a sample
/// arrive within milliseconds, far fewer samples apart.
const SEEN: usize = 4096;

/// The two readers of one shape topic.
pub struct ShapeReaders<M> {
    pub volatile: Subscription<M>,
    pub transient_local: Subscription<M>,
}

#[derive(Default)]
struct Seen {
    order: VecDeque<(Gid, i64)>,
    set: HashSet<(Gid, i64)>,
}

impl Seen {
    /// True the first time a sample (writer, sequence number) is seen.
    fn first(&mut self, key: (Gid, i64)) -> bool {
        if !self.set.insert(key) {
            return false;
        }
        self.order.push_back(key);
        if self.order.len() > SEEN {
            if let Some(old) = self.order.pop_front() {
                self.set.remove(&old);
            }
        }
        true
    }
}

impl<M: serde::de::DeserializeOwned + 'static> ShapeReaders<M> {
    /// Samples of both readers, each once.
    pub fn async_stream(&self) -> impl Stream<Item = ReadResult<(M, MessageInfo)>> + '_ {
        let mut seen = Seen::default();
        futures::stream::select(
            self.volatile.async_stream(),
            self.transient_local.async_stream(),
        )
        .filter(move |r| {
            let keep = match r {
                Ok((_, info)) => seen.first((info.publisher_gid(), info.sequence_number())),
                Err(_) => true,
            };
            futures::future::ready(keep)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_second_copy_is_dropped_and_memory_is_bounded() {
        let mut s = Seen::default();
        let g = |k: u8| Gid::from([k; 16]);
        assert!(s.first((g(1), 1)));
        assert!(!s.first((g(1), 1)));
        assert!(s.first((g(1), 2)));
        assert!(s.first((g(2), 1)));
        for k in 0..2 * SEEN as i64 {
            s.first((g(3), k));
        }
        assert_eq!(s.order.len(), SEEN);
        assert_eq!(s.set.len(), SEEN);
        // Long gone: a new copy would pass again.
        assert!(s.first((g(1), 1)));
    }
}
