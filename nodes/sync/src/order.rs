//! Events in the order they happened, as far as `sync` needs it.
//!
//! dora's event scheduler hands out control events (`InputClosed`, `Stop`) before the inputs
//! queued ahead of them, so a source's `InputClosed` can arrive before its last frames. `sync`
//! ends its run when every source has closed; taken in the scheduler's order, those last frames
//! would be left unread and the sets they complete never sent. [`InputsFirst`] restores the
//! order: when a control event comes, the inputs already buffered are handed out first, then
//! the control event, then any other control events buffered with them.

use std::collections::VecDeque;

use dora_node_api::{Event, EventStream};

/// Where events come from: the next one (blocking) and everything buffered (not blocking).
pub(crate) trait Source<T> {
    fn next(&mut self) -> Option<T>;
    fn buffered(&mut self) -> Vec<T>;
}

impl Source<Event> for EventStream {
    fn next(&mut self) -> Option<Event> {
        self.recv()
    }
    fn buffered(&mut self) -> Vec<Event> {
        self.drain().unwrap_or_default()
    }
}

/// Hands out inputs queued before a control event ahead of it.
pub(crate) struct InputsFirst<T> {
    pending: VecDeque<T>,
    is_input: fn(&T) -> bool,
}

impl InputsFirst<Event> {
    /// For dora's events: `Event::Input` is an input, every other event a control event.
    pub(crate) fn dora() -> Self {
        Self::new(|e| matches!(e, Event::Input { .. }))
    }
}

impl<T> InputsFirst<T> {
    pub(crate) fn new(is_input: fn(&T) -> bool) -> Self {
        Self {
            pending: VecDeque::new(),
            is_input,
        }
    }

    /// The next event; `None` when the source has ended and nothing is pending.
    pub(crate) fn next(&mut self, source: &mut impl Source<T>) -> Option<T> {
        if let Some(e) = self.pending.pop_front() {
            return Some(e);
        }
        let event = source.next()?;
        if (self.is_input)(&event) {
            return Some(event);
        }
        let (inputs, controls): (Vec<T>, Vec<T>) = source
            .buffered()
            .into_iter()
            .partition(|e| (self.is_input)(e));
        self.pending.extend(inputs);
        self.pending.push_back(event);
        self.pending.extend(controls);
        self.pending.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An event: an input (its input id and sequence number) or a control event.
    #[derive(Debug, Clone, Copy, PartialEq)]
    enum E {
        In(&'static str, u32),
        Closed(&'static str),
        Stop,
    }

    /// Events as dora's scheduler hands them out: the ones that have arrived by each
    /// `next` (a batch) come out control events first.
    struct Scheduled {
        batches: VecDeque<Vec<E>>,
        queue: VecDeque<E>,
    }

    impl Scheduled {
        fn new(batches: Vec<Vec<E>>) -> Self {
            Self {
                batches: batches.into(),
                queue: VecDeque::new(),
            }
        }
        /// Blocks, as `recv` does, until a batch brings something.
        fn arrive(&mut self) {
            while self.queue.is_empty()
                && let Some(batch) = self.batches.pop_front()
            {
                let (inputs, controls): (Vec<E>, Vec<E>) =
                    batch.into_iter().partition(|e| matches!(e, E::In(..)));
                self.queue.extend(controls);
                self.queue.extend(inputs);
            }
        }
    }

    impl Source<E> for Scheduled {
        fn next(&mut self) -> Option<E> {
            self.arrive();
            self.queue.pop_front()
        }
        fn buffered(&mut self) -> Vec<E> {
            self.queue.drain(..).collect()
        }
    }

    fn all(batches: Vec<Vec<E>>) -> Vec<E> {
        let mut source = Scheduled::new(batches);
        let mut order = InputsFirst::new(|e| matches!(e, E::In(..)));
        std::iter::from_fn(|| order.next(&mut source)).collect()
    }

    #[test]
    fn a_close_comes_after_the_inputs_queued_before_it() {
        use E::*;
        let got = all(vec![
            vec![In("a", 0)],
            vec![In("a", 1), In("b", 0), In("a", 2), Closed("a")],
            vec![In("b", 1), Closed("b"), Stop],
        ]);
        assert_eq!(
            got,
            [
                In("a", 0),
                In("a", 1),
                In("b", 0),
                In("a", 2),
                Closed("a"),
                In("b", 1),
                Closed("b"),
                Stop
            ]
        );
        // The scheduler's own order put the closes first.
        let mut raw = Scheduled::new(vec![vec![In("a", 1), Closed("a")]]);
        assert_eq!(raw.next(), Some(Closed("a")));
    }

    #[test]
    fn nothing_is_lost_or_repeated() {
        use E::*;
        let batches = vec![
            vec![Closed("x"), Stop],
            vec![],
            vec![In("a", 0), In("a", 1)],
            vec![Stop, In("b", 0), Closed("a"), Closed("b"), In("b", 1)],
        ];
        let mut expected: Vec<E> = batches.iter().flatten().copied().collect();
        let mut got = all(batches);
        let key = |e: &E| format!("{e:?}");
        expected.sort_by_key(key);
        got.sort_by_key(key);
        assert_eq!(got, expected);
    }
}
