//! Who takes the card's lock next (issue 33). Two kinds of work want it: a host's request,
//! whose work is bounded (one command, or a packet's worth of answers), and the rest of a
//! line its host abandoned by sending another line before fetching the whole reply (a
//! "leftover", up to a whole line of ranges, 0.1 s, that nobody waits to read). Requests go
//! first; leftovers take the card one at a time among themselves, so that a poller's `???`
//! waits behind at most one command however many connections abandon long lines.
//!
//! The standard mutex is not fair: a thread that releases the card and takes it again at once
//! keeps a woken waiter out. So the leftover holding its turn steps aside while a request
//! waits (at most [`LEFTOVER_WAIT_MAX`] a step, so that a stream of requests never stops it),
//! and sleeps rather than spins, leaving the core to the request.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Duration;

/// The longest the leftover holding its turn waits for requests to go first, before each of its
/// steps: a few `???` round trips, and still hundreds of steps a second under any stream of
/// requests.
pub const LEFTOVER_WAIT_MAX: Duration = Duration::from_millis(2);

/// How often a leftover waiting for its turn looks whether its host is still there: one that
/// left gives up its place (a thread per departed host waited behind the others otherwise:
/// 1,131 threads in a 30 s soak, for 128 connections).
pub const LEFTOVER_HOST_CHECK: Duration = Duration::from_millis(50);

/// The turns of one card's lock.
#[derive(Default)]
pub struct CardTurns {
    /// Whether a leftover holds its turn.
    leftover_turn: Mutex<bool>,
    turn_free: Condvar,
    /// Requests waiting for the card.
    requests_waiting: AtomicUsize,
    /// Where the leftover holding its turn sleeps while requests go first.
    requests_gone: (Mutex<()>, Condvar),
}

/// A leftover's turn: released when dropped.
pub struct LeftoverTurn<'a> {
    turns: &'a CardTurns,
}

impl Drop for LeftoverTurn<'_> {
    fn drop(&mut self) {
        *lock(&self.turns.leftover_turn) = false;
        self.turns.turn_free.notify_one();
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl CardTurns {
    /// Takes the card with `take` for a request: at once, competing only with the one
    /// leftover that holds its turn, which steps aside.
    pub fn request<G>(&self, take: impl FnOnce() -> G) -> G {
        self.requests_waiting.fetch_add(1, Ordering::SeqCst);
        let card = take();
        if self.requests_waiting.fetch_sub(1, Ordering::SeqCst) == 1 {
            let (m, gone) = &self.requests_gone;
            let _g = lock(m);
            gone.notify_all();
        }
        card
    }

    /// Takes the card with `take` for a leftover, once its turn comes and no request waits (or
    /// [`LEFTOVER_WAIT_MAX`] has passed); `None` if `host_gone` says its host left while it
    /// waited for its turn.
    pub fn leftover<G>(&self, take: impl FnOnce() -> G, host_gone: &dyn Fn() -> bool) -> Option<(G, LeftoverTurn<'_>)> {
        let mut held = lock(&self.leftover_turn);
        while *held {
            held = self.turn_free.wait_timeout(held, LEFTOVER_HOST_CHECK).unwrap_or_else(|e| e.into_inner()).0;
            if *held && host_gone() {
                return None;
            }
        }
        *held = true;
        drop(held);
        let turn = LeftoverTurn { turns: self };
        if self.requests_waiting.load(Ordering::SeqCst) > 0 {
            let (m, gone) = &self.requests_gone;
            let _ = gone
                .wait_timeout_while(lock(m), LEFTOVER_WAIT_MAX, |_| self.requests_waiting.load(Ordering::SeqCst) > 0)
                .unwrap_or_else(|e| e.into_inner());
        }
        Some((take(), turn))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    use std::time::Instant;

    #[test]
    fn a_leftover_whose_host_left_gives_up_its_place_in_the_queue() {
        let turns = Arc::new(CardTurns::default());
        let (_, holder) = turns.leftover(|| (), &|| false).unwrap();
        let gone = Arc::new(AtomicBool::new(false));
        let waiter = {
            let (turns, gone) = (turns.clone(), gone.clone());
            std::thread::spawn(move || turns.leftover(|| (), &|| gone.load(Ordering::SeqCst)).is_none())
        };
        std::thread::sleep(Duration::from_millis(20));
        let t = Instant::now();
        gone.store(true, Ordering::SeqCst);
        assert!(waiter.join().unwrap(), "gave up");
        assert!(t.elapsed() < Duration::from_secs(2));
        drop(holder);
        assert!(turns.leftover(|| (), &|| false).is_some(), "the turn is free again");
    }

    #[test]
    fn a_request_never_waits_for_a_leftover_s_turn() {
        let turns = CardTurns::default();
        let (_, _holder) = turns.leftover(|| (), &|| false).unwrap();
        assert_eq!(turns.request(|| 7), 7);
    }
}
