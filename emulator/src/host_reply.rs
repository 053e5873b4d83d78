//! One host connection's reply, answered as the host fetches it (issue 33). The card answers
//! a line a command at a time ([`Card::line_step`]), the card's lock taken for each command
//! and released between them, and only until a packet's worth of answers waits: the rest
//! comes as the host asks for it with GETBUFFER (a reply over 1,400 bytes comes in 1,400-byte
//! packets, docs/emulator.md). A connection therefore holds at most a packet and one command's
//! answers (a range is answered [`crate::card::RANGE_PART_MAX`] variables at a time), however
//! large the reply: 128 connections asking for replies of 24 MB each took 1.6 GB before.

use crate::card::{Card, LineRun, Progress};
use crate::protocol::REPLY_PACKET_BYTES;
use pmacwd_specs::grammar::Addressing;
use std::ops::DerefMut;

/// Why the card is wanted: for a request, whose work is bounded (a packet's worth of
/// answers), or for the rest of a line its host abandoned, which may be a whole line of ranges
/// (0.1 s) that nobody waits for (`card_turns` says who goes first). The card for a turn may
/// be refused (`None`) to a leftover whose host left while it waited.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Turn {
    Request,
    Leftover,
}

/// What a connection has of its current line.
#[derive(Default)]
pub struct HostReply {
    /// The line being answered, until it ends.
    run: Option<LineRun>,
    /// Answers not yet sent.
    waiting: Vec<u8>,
}

impl HostReply {
    /// Starts answering `line`. A line the host left unfinished (it sent another line before
    /// fetching the whole reply) runs to its end first, its answers dropped: the card runs the
    /// commands it read, in order (MODEL: what a card answers to a line whose reply the host
    /// abandoned is not in the pages at hand; the emulator always dropped such a reply, and
    /// runs every command it read, as it did when it answered lines whole). A host that leaves
    /// drops the rest instead (`server::host_session`).
    pub fn start<G: DerefMut<Target = Card>>(
        &mut self,
        line: &[u8],
        card: &impl Fn(Turn) -> Option<G>,
        addressing: &mut Addressing,
        host_gone: &impl Fn() -> bool,
    ) {
        self.finish(card, addressing, host_gone);
        self.run = Some(LineRun::new(line));
    }

    /// Runs commands, one hold of the card's lock each, while less than a packet waits and
    /// the line goes on. How the line ended, if it ended now; a silent card (tripped, UM
    /// p.215) drops what waited.
    pub fn fill<G: DerefMut<Target = Card>>(
        &mut self,
        card: &impl Fn(Turn) -> Option<G>,
        addressing: &mut Addressing,
    ) -> Option<Progress> {
        while self.waiting.len() < REPLY_PACKET_BYTES {
            let run = self.run.as_mut()?;
            let mut card = card(Turn::Request)?;
            let progress = card.line_step(run, addressing, &mut self.waiting);
            drop(card);
            if let Progress::Waiting(wait) = progress {
                pause(wait);
                continue;
            }
            if progress != Progress::More {
                self.run = None;
                if progress == Progress::Silent {
                    self.waiting.clear();
                }
                return Some(progress);
            }
        }
        None
    }

    /// Whether answers wait to be fetched.
    pub fn has_waiting(&self) -> bool {
        !self.waiting.is_empty()
    }

    /// The next packet of what waits (empty when nothing does).
    pub fn next_packet(&mut self) -> Vec<u8> {
        let n = self.waiting.len().min(REPLY_PACKET_BYTES);
        let packet: Vec<u8> = self.waiting.drain(..n).collect();
        if self.waiting.capacity() > 4 * REPLY_PACKET_BYTES {
            // A range part's answers may have grown it; keep the connection's share small.
            self.waiting.shrink_to(2 * REPLY_PACKET_BYTES);
        }
        packet
    }

    /// The host flushed: what waited is dropped, and so are the line's commands not yet run.
    /// SRM p.263 (<CTRL-X>, which the flush request stands for): the card stops sending what it
    /// had started to send. MODEL: that the commands of the line not yet run are dropped with
    /// it; <CTRL-X> also empties the queue of commands from the host.
    pub fn flush(&mut self) {
        self.run = None;
        self.waiting.clear();
    }

    /// Runs what is left of the line, its answers dropped (the host sent another line). The
    /// lock is still taken per command. Stops, the rest dropped as when a host leaves, once
    /// `host_gone` says the host has gone meanwhile: a leftover waits behind requests, and a
    /// thread finishing a line for a host that left kept running for minutes (1,138 threads in
    /// a 30 s soak, for 128 connections).
    pub fn finish<G: DerefMut<Target = Card>>(
        &mut self,
        card: &impl Fn(Turn) -> Option<G>,
        addressing: &mut Addressing,
        host_gone: &impl Fn() -> bool,
    ) {
        self.waiting.clear();
        if let Some(mut run) = self.run.take() {
            let mut scratch = Vec::new();
            while !host_gone() {
                let Some(mut card) = card(Turn::Leftover) else { break };
                match card.line_step(&mut run, addressing, &mut scratch) {
                    Progress::More => {}
                    Progress::Waiting(wait) => {
                        drop(card);
                        pause(wait);
                    }
                    Progress::Ended | Progress::Failed | Progress::Silent => break,
                }
                scratch.clear();
            }
        }
    }
}

/// A line waits for the card's background (`Progress::Waiting`) with the card's lock released:
/// `wait` asleep, or, when it is zero (virtual time, where the card itself ran towards it),
/// a yield so that others may take the card first.
fn pause(wait: std::time::Duration) {
    if wait.is_zero() {
        std::thread::yield_now();
    } else {
        std::thread::sleep(wait);
    }
}
