//! The choices the search made for one candidate, linked back to the start: what the
//! explanation is rebuilt from.

use super::gap::Plan;
use pmacwd_specs::check::ResetEvent;
use std::sync::Arc;

/// One choice the search made, linked to the choices before it.
pub struct Node {
    pub parent: Option<Arc<Node>>,
    /// The 1-based capture event it was made at.
    pub event: u64,
    pub kind: NodeKind,
}

#[derive(Debug)]
pub enum NodeKind {
    Start {
        cpu: u8,
    },
    /// A checkpoint of a long capture (`search::Checkpoint`): the search had one candidate here,
    /// whose choices before are another segment's; the chain starts again.
    Root,
    Gap {
        plan_hi: Plan,
        plan_lo: Plan,
        lo: i32,
        end: super::End,
    },
    Restart(ResetEvent),
    /// A command the host gave up on after `cycles` servo cycles with no background cycle;
    /// `late`: the card processed it right after the wait (MODEL: it may not have seen the
    /// host's flush, `Controller::unanswered`).
    Wait {
        cycles: u32,
        late: bool,
    },
    /// X:$25 read as this value, where the search had an interval.
    Pin(i32),
    /// Y:$25 read as this value, where the search had an interval.
    CounterPin(i32),
    /// At a status read, the checksum engine on this area at the start of a pass: the card's
    /// pass lengths are its own, taken from what bit 12 shows (`Tolerances::free_area`).
    Area(pmacwd_specs::check::ChecksumTarget),
}

impl std::fmt::Debug for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Node(event {})", self.event)
    }
}

impl Drop for Node {
    /// A day-long capture links hundreds of thousands of nodes: drop them in a loop, not by
    /// recursion.
    fn drop(&mut self) {
        let mut next = self.parent.take();
        while let Some(rc) = next {
            match Arc::try_unwrap(rc) {
                Ok(mut node) => next = node.parent.take(),
                Err(_) => break,
            }
        }
    }
}

/// The nodes from the start to `last`, oldest first.
pub fn chain(last: &Arc<Node>) -> Vec<Arc<Node>> {
    let mut v = vec![last.clone()];
    while let Some(p) = v.last().and_then(|n| n.parent.clone()) {
        v.push(p);
    }
    v.reverse();
    v
}
