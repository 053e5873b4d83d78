//! Transition monitors: properties about what one event may change.
//!
//! stateright properties look at one state at a time. A sentence like "a locked I-variable
//! never changes through an I-variable write" is about a transition, so the checker runs each
//! monitor on (state before, event, reply, state after) and records a failure as a sticky bit
//! in the next state; the matching `always` property requires that bit to stay clear. A
//! monitor never influences the semantics, and a model that obeys every monitor adds no state.

use crate::controller::{Controller, CycleReport};
use pmacwd_specs::check::ChecksumTarget;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::command::{HostCommand, Register};
use pmacwd_specs::vocab::event::{Event, Reply};

/// A transition monitor: its property name, the sentence it encodes, and its check.
pub struct Monitor {
    pub name: &'static str,
    pub cite: &'static str,
    pub sentence: &'static str,
    pub check: Check,
}

pub enum Check {
    /// Checked after every event.
    Event(fn(&ModelConfig, &Controller, &Event, Reply, &Controller) -> bool),
    /// Checked after every single servo cycle.
    Cycle(fn(&ModelConfig, &Controller, CycleReport, &Controller) -> bool),
}

fn is_reset(event: &Event) -> bool {
    matches!(event, Event::Reset(_) | Event::Command(HostCommand::Reset))
}

fn locked(cfg: &ModelConfig, c: &Controller, n: u16) -> bool {
    cfg.lockout_bit(n).is_some_and(|bit| c.i41 & (1 << bit) != 0)
}

fn running(c: &Controller) -> bool {
    !c.tripped() && !c.bootstrap
}

/// `a` implies `b`: how the sentences read.
fn implies(a: bool, b: bool) -> bool {
    !a || b
}

fn bit(word: u32, b: u8) -> bool {
    word & (1 << b) != 0
}

pub const MONITORS: &[Monitor] = &[
    Monitor {
        name: "a tripped card does not reply to any command",
        cite: "UM p.215",
        sentence: "The processor stops operating and will not communicate.",
        check: Check::Event(|_, prev, ev, reply, _| !(prev.tripped() && matches!(ev, Event::Command(_))) || reply == Reply::Silence),
    },
    Monitor {
        name: "a trip is undone only by INIT/ or a power cycle",
        cite: "UM p.215",
        sentence: "power to the Turbo PMAC must be cycled off and on, or the INIT/ hardware reset line must be taken low, then high, to restore normal functioning.",
        check: Check::Event(|_, prev, ev, _, next| implies(prev.tripped() && !next.tripped(), matches!(ev, Event::Reset(_)))),
    },
    Monitor {
        name: "a tripped card changes no state until it is reset",
        cite: "UM p.215",
        sentence: "the system is latched into a reset state ... The processor stops operating.",
        check: Check::Event(|_, prev, ev, _, next| {
            if !prev.tripped() || matches!(ev, Event::Reset(_)) {
                return true;
            }
            let mut same = next.clone();
            same.supply_low = prev.supply_low;
            same == *prev
        }),
    },
    Monitor {
        name: "a locked I-variable never changes through an I-variable write",
        cite: "SRM p.57",
        sentence: "If the bit of I41 is set to 1, the corresponding I-variables cannot be changed with an {I-variable}={value} command.",
        check: Check::Event(|cfg, prev, ev, _, next| match ev {
            Event::Command(HostCommand::WriteI(n, _)) if running(prev) && locked(cfg, prev, *n) => next.i_variable(*n) == prev.i_variable(*n),
            _ => true,
        }),
    },
    Monitor {
        name: "a locked I-variable write is ignored without an error",
        cite: "SRM p.57",
        sentence: "the command is ignored (no error is generated).",
        check: Check::Event(|cfg, prev, ev, reply, _| match ev {
            Event::Command(HostCommand::WriteI(n, _)) if running(prev) && locked(cfg, prev, *n) => reply == Reply::Ack,
            _ => true,
        }),
    },
    Monitor {
        name: "I41 itself is never locked out",
        cite: "SRM p.57",
        sentence: "The following table shows the I-variable set that each bit of I41 controls (I41 is in none of them).",
        check: Check::Event(|cfg, prev, ev, _, next| match ev {
            Event::Command(HostCommand::WriteI(41, v)) if running(prev) && cfg.i41_range.0 <= *v && *v <= cfg.i41_range.1 => next.i_variable(41) == *v,
            _ => true,
        }),
    },
    Monitor {
        name: "an I-variable write outside every locked range takes effect",
        cite: "SRM p.57",
        sentence: "each bit independently controls access to a set of I-variables.",
        check: Check::Event(|cfg, prev, ev, reply, next| match ev {
            Event::Command(HostCommand::WriteI(n, v)) if running(prev) && !locked(cfg, prev, *n) && reply == Reply::Ack => next.i_variable(*n) == *v,
            _ => true,
        }),
    },
    Monitor {
        name: "bit 22 once set stays set until reset or an explicit clear",
        cite: "SRM p.289",
        sentence: "It stays at 1 until the card is reset, or until this bit is manually changed to 0.",
        check: Check::Event(|_, prev, ev, _, next| {
            implies(prev.status.rti_reentry && !next.status.rti_reentry, is_reset(ev) || matches!(ev, Event::ClearRtiReentry))
        }),
    },
    Monitor {
        name: "an RTI overrun sets bits 22 and 9",
        cite: "SRM p.289-290",
        sentence: "Bit 22 ... still executing when the next real-time interrupt came; bit 9 ... took more than one interrupt period.",
        check: Check::Cycle(|cfg, _, report, next| {
            let (x, _) = next.status_words(cfg);
            !report.rti_overrun || (bit(x, cfg.layout.rti_reentry.1) && bit(x, cfg.layout.rti_warning.1))
        }),
    },
    Monitor {
        name: "PLC 0 starts only when the previous RTI tasks have completed",
        cite: "UM p.236",
        sentence: "PLC 0 and PLCC 0 will execute every real-time interrupt as long as the tasks from the previous RTI have been completed.",
        check: Check::Cycle(|_, prev, report, _| !report.rti_started || prev.rti_remaining == 0),
    },
    Monitor {
        name: "the watchdog counter drops by at most one per servo cycle",
        cite: "SRM p.57",
        sentence: "Each servo interrupt cycle, Turbo PMAC decrements this counter by 1 automatically.",
        check: Check::Cycle(|_, prev, _, next| matches!(prev.counter - next.counter, 0 | 1)),
    },
    Monitor {
        name: "a background cycle reloads the counter from I40",
        cite: "UM p.215",
        sentence: "At the end of each background cycle, the CPU resets the counter value to a maximum value set by variable I40 (or to 4096 if I40 is set to the default of 0).",
        check: Check::Event(|cfg, prev, ev, _, next| !matches!(ev, Event::Background) || !prev.background_possible() || next.counter == cfg.reset_value(prev.i40)),
    },
    Monitor {
        name: "X:$25 never rises except at a reset",
        cite: "SRM p.57",
        sentence: "Register X:$25 contains the lowest value that the counter has reached before being reset since the last power-on/reset.",
        check: Check::Event(|_, prev, ev, _, next| next.counter_min <= prev.counter_min || is_reset(ev)),
    },
    Monitor {
        name: "a checksum error freezes X:$1080",
        cite: "UM p.217",
        sentence: "stops performing any checksum operations. This leaves the calculated value frozen in the running checksum register X:$001080.",
        check: Check::Event(|cfg, prev, ev, _, next| {
            prev.checksum.error.is_none() || is_reset(ev) || prev.register(cfg, Register::RunningChecksum) == next.register(cfg, Register::RunningChecksum)
        }),
    },
    Monitor {
        name: "a checksum error stops both checksums",
        cite: "UM p.217",
        sentence: "stops performing any program or firmware checksum operations (communications checksum is independent).",
        check: Check::Event(|_, prev, ev, _, next| {
            prev.checksum.error.is_none() || is_reset(ev) || (next.checksum.area == prev.checksum.area && next.checksum.error == prev.checksum.error)
        }),
    },
    Monitor {
        name: "the ??? reply is twelve hex characters, first word first",
        cite: "SRM p.289",
        sentence: "Turbo PMAC returns twelve characters, representing two status words.",
        check: Check::Event(|cfg, _, ev, reply, next| match (ev, reply) {
            (Event::Command(HostCommand::GlobalStatus), Reply::Status { x, y }) => {
                let text = reply.to_string();
                text.len() == 12 && u32::from_str_radix(&text[..6], 16) == Ok(x) && u32::from_str_radix(&text[6..], 16) == Ok(y) && (x, y) == next.status_words(cfg)
            }
            _ => true,
        }),
    },
    Monitor {
        name: "a card in bootstrap mode answers ??? with BOOTSTRAP PROM",
        cite: "SRM p.289",
        sentence: "If the Turbo PMAC is in bootstrap mode ... its response to this command will simply be BOOTSTRAP PROM.",
        check: Check::Event(|_, prev, ev, reply, _| {
            !(prev.bootstrap && !prev.tripped() && matches!(ev, Event::Command(HostCommand::GlobalStatus))) || reply == Reply::Bootstrap
        }),
    },
    Monitor {
        name: "the DPRAM and flash error bits change only at a reset",
        cite: "SRM p.289",
        sentence: "Bit 11 ... automatic DPRAM check function at power-up/reset; Bit 10 ... reading saved data from the flash memory on board reset.",
        check: Check::Event(|_, prev, ev, _, next| {
            (prev.status.dpram_error == next.status.dpram_error && prev.status.flash_error == next.status.flash_error) || is_reset(ev)
        }),
    },
    Monitor {
        name: "a supply below the minimum trips the card at once",
        cite: "UM p.215",
        sentence: "If the supply voltage is below this value, the circuit's relay will trip and the card will shut down.",
        check: Check::Event(|cfg, _, ev, _, next| match ev {
            Event::Supply { millivolts } if *millivolts < cfg.supply_min_millivolts => next.tripped(),
            _ => true,
        }),
    },
    Monitor {
        name: "a firmware checksum error sets bits 12 and 13",
        cite: "UM p.217",
        sentence: "it sets global status bits (bits 12 and 13 of X:$000006 ...) and stops performing any checksum operations.",
        check: Check::Event(|cfg, prev, _, _, next| {
            let (x, _) = next.status_words(cfg);
            !(prev.checksum.error.is_none() && next.checksum.error == Some(ChecksumTarget::Firmware))
                || (bit(x, cfg.layout.checksum_error.1) && bit(x, cfg.layout.prom_checksum_active.1))
        }),
    },
];
