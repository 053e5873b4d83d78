//! Transition monitors: properties about what one event may change.
//!
//! stateright properties look at one state at a time. A sentence like "a locked I-variable
//! never changes through an I-variable write" is about a transition, so the checker runs each
//! monitor on (state before, event, reply, state after) and records a failure as a sticky bit
//! in the next state; the matching `always` property requires that bit to stay clear. A
//! monitor never influences the semantics, and a model that obeys every monitor adds no state.

use crate::controller::{Controller, CycleReport};
use crate::motion::{Program, Stop};
use pmacwd_specs::check::ChecksumTarget;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::EncoderLossClear;
use pmacwd_specs::vocab::command::{CsCommand, GlobalCommand, Motion, MotorCommand};
use pmacwd_specs::vocab::command::{HostCommand, Register};
use pmacwd_specs::vocab::event::{Event, Reply};
use pmacwd_specs::vocab::MotorState;

/// UM p.215's "approximately 4.75V", as printed: what the supply monitor reads, and what the
/// checker offers supply readings on both sides of (not `watchdog.yaml`'s copy the rule reads,
/// which a mutation may move).
pub const SUPPLY_MIN_MILLIVOLTS_PRINTED: u32 = 4_750;

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
    matches!(event, Event::Reset(_) | Event::Command(HostCommand::Reset | HostCommand::Reinitialize))
}

fn locked(cfg: &ModelConfig, c: &Controller, n: u16) -> bool {
    cfg.lockout_bit(n).is_some_and(|bit| c.i41 & (1 << bit) != 0)
}

/// The value an acknowledged assignment of `v` to I`n` leaves: `v`, or for I8, I40 and I41
/// (the ranges the model knows) what the reading `out_of_range_assignment` makes of it (None:
/// refused, UM p.243's modulo otherwise).
fn assigned(cfg: &ModelConfig, n: u16, v: i64) -> Option<i64> {
    match n {
        8 => cfg.out_of_range().stored(v, cfg.i8_range),
        40 => cfg.out_of_range().stored(v, cfg.i40_range),
        41 => cfg.out_of_range().stored(v, cfg.i41_range),
        _ => Some(v),
    }
}

fn running(c: &Controller) -> bool {
    !c.tripped() && !c.bootstrap
}

/// `a` implies `b`: how the sentences read. A macro, so that `b` is evaluated only when `a`
/// holds, as `!a || b` would: a function evaluates both first, and the checker runs these
/// monitors on every transition and every servo cycle of a leap, where `b` (a program looked
/// up per motor, say) is the dear part and `a` is almost always false (measured with
/// callgrind: docs/model.md, "Against SPIN").
macro_rules! implies {
    ($a:expr, $b:expr $(,)?) => {
        !$a || $b
    };
}

fn bit(word: u32, b: u8) -> bool {
    word & (1 << b) != 0
}

/// The motion command of `ev`, when the card ran it (it was running before).
fn motion(prev: &Controller, ev: &Event) -> Option<Motion> {
    match ev {
        Event::Command(HostCommand::Motion(m)) if running(prev) => Some(*m),
        _ => None,
    }
}

/// The motors (0-based) of coordinate system `cs`.
fn members(cfg: &ModelConfig, cs: u8) -> impl Iterator<Item = usize> + '_ {
    (1..=cfg.motion.motors).filter(move |m| cfg.motion.coordinate_system(*m) == cs).map(|m| usize::from(m) - 1)
}

fn program(c: &Controller, cs: u8) -> Program {
    c.axes.programs()[usize::from(cs) - 1]
}

fn cs_of(cfg: &ModelConfig, k: usize) -> u8 {
    cfg.motion.coordinate_system(k as u8 + 1)
}

/// Whether the text of a `Status { x, y }` reply is twelve hex characters, `x` first.
///
/// The text depends on the reply alone and writing it allocates, while the checker meets the
/// same few status words on tens of thousands of transitions: each reply's answer is kept (per
/// thread, as the checker's threads run monitors side by side).
fn status_text_is_the_words(reply: Reply) -> bool {
    /// More distinct status words than a configuration shows; past them, no memory.
    const REMEMBERED_MAX: usize = 64;
    thread_local! {
        static SEEN: std::cell::RefCell<Vec<(Reply, bool)>> = const { std::cell::RefCell::new(Vec::new()) };
    }
    let Reply::Status { x, y } = reply else { return false };
    SEEN.with_borrow_mut(|seen| {
        if let Some((_, answer)) = seen.iter().find(|(r, _)| *r == reply) {
            return *answer;
        }
        let text = reply.to_string();
        let answer = text.len() == 12
            && u32::from_str_radix(&text[..6], 16) == Ok(x)
            && u32::from_str_radix(&text[6..], 16) == Ok(y);
        if seen.len() < REMEMBERED_MAX {
            seen.push((reply, answer));
        }
        answer
    })
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
        check: Check::Event(|_, prev, ev, _, next| implies!(prev.tripped() && !next.tripped(), matches!(ev, Event::Reset(_)))),
    },
    Monitor {
        name: "a tripped card changes no state until it is reset",
        cite: "UM p.215",
        sentence: "the system is latched into a reset state ... The processor stops operating.",
        check: Check::Event(|_, prev, ev, _, next| {
            // `next == prev` first: most events leave a tripped card as it was, and then it needs
            // no copy (this runs on every transition from a tripped state).
            if !prev.tripped() || matches!(ev, Event::Reset(_)) || next == prev {
                return true;
            }
            // The supply, the encoder-loss and the amplifier-fault inputs are hardware inputs,
            // not the card's state.
            let mut same = next.clone();
            same.supply_low = prev.supply_low;
            for (s, p) in same.axes.motors_mut().iter_mut().zip(prev.axes.motors()) {
                s.encoder_lost = p.encoder_lost;
                s.amplifier_fault = p.amplifier_fault;
            }
            same == *prev
        }),
    },
    Monitor {
        name: "a supply change trips a running card exactly when it falls below 4.75 V",
        cite: "UM p.215",
        sentence: "it must see a DC voltage greater than approximately 4.75V. If the supply voltage is below this value, the circuit's relay will trip and the card will shut down.",
        // The figure as printed, not `watchdog.yaml`'s copy the rule reads: a threshold moved
        // either way in the data (or the rule) breaks this where a configuration offers a
        // supply at the edge (check.yaml `edges`: 4,750 and 4,749 mV), since the checker offers
        // readings on both sides of the printed figure too.
        check: Check::Event(|_, prev, ev, _, next| match ev {
            Event::Supply { millivolts } if running(prev) => {
                next.tripped() == (*millivolts < SUPPLY_MIN_MILLIVOLTS_PRINTED)
            }
            _ => true,
        }),
    },
    Monitor {
        name: "CLOSE stores the user program's checksum as it stands in X:$1090",
        cite: "UM p.217",
        sentence: "it compares this value to the checksum value that was computed the last time one of these buffers was closed, stored in X:$001090.",
        check: Check::Event(|_, prev, ev, _, next| match ev {
            Event::Command(HostCommand::Close) if running(prev) => {
                next.checksum.program_reference == prev.checksum.program
            }
            _ => true,
        }),
    },
    Monitor {
        name: "bit 19 of ??? is set by GATHER and cleared by ENDGATHER or a reset, and by nothing else",
        cite: "SRM p.289",
        sentence: "Bit 19 Data Gathering Function On : This bit is 1 when the data gathering function is active; it is 0 when the function is not active. (SRM p.307: Data Gathering is in progress while an ENDGATHER command has not been issued and the gather buffer has not been filled up.)",
        // Bit 19 of the first word as SRM p.289 prints it, not status.yaml's layout: a driven
        // bit misplaced onto it (or gathering's flag onto another bit) is caught. MODEL: a reset
        // ends gathering; the gather buffer never fills (wrap-around, SRM p.170).
        // The words are built only where the bit is read: the checker runs this on every
        // transition, and where the card's inputs to the words did not change
        // (`Controller::status_inputs`) neither did the words.
        check: Check::Event(|cfg, prev, ev, _, next| {
            let before = || bit(prev.status_words(cfg).0, 19);
            let after = || bit(next.status_words(cfg).0, 19);
            match ev {
                Event::Command(HostCommand::Gather) if running(prev) => after(),
                Event::Command(HostCommand::EndGather) if running(prev) => !after(),
                Event::Reset(_) => !after(),
                Event::Command(HostCommand::Reset | HostCommand::Reinitialize) if running(prev) => !after(),
                _ => prev.status_inputs() == next.status_inputs() || after() == before(),
            }
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
            Event::Command(HostCommand::WriteI(41, v)) if running(prev) && assigned(cfg, 41, *v).is_some() => next.i_variable(41) == assigned(cfg, 41, *v),
            _ => true,
        }),
    },
    Monitor {
        name: "an I-variable write outside every locked range takes effect",
        cite: "SRM p.57",
        sentence: "each bit independently controls access to a set of I-variables.",
        check: Check::Event(|cfg, prev, ev, reply, next| match ev {
            Event::Command(HostCommand::WriteI(n, v)) if running(prev) && !locked(cfg, prev, *n) && reply == Reply::Ack => next.i_variable(*n) == assigned(cfg, *n, *v),
            _ => true,
        }),
    },
    Monitor {
        name: "an I-variable write takes effect exactly when the I41 bit of its range in SRM p.57's table is clear",
        cite: "SRM p.57",
        sentence: "I41 Bit # 0 (1): I100-I4899 Motor Setup; 1 (2): I5100-I6699 Coordinate System Setup; 2 (4): I6800-I7999 MACRO/Servo IC Setup; 3 (8): I8000-I8191 Conversion Table Setup.",
        // The table as the page prints it, not `variables.yaml`'s copy that the rule reads:
        // a bit swapped in the data (or in the rule) breaks this and nothing else.
        check: Check::Event(|cfg, prev, ev, reply, next| match ev {
            Event::Command(HostCommand::WriteI(n, v)) if running(prev) && reply == Reply::Ack && *n != 41 => {
                const PRINTED: [(u8, u16, u16); 4] = [(1, 100, 4899), (2, 5100, 6699), (4, 6800, 7999), (8, 8000, 8191)];
                let locked = PRINTED.iter().any(|(value, first, last)| prev.i41 & value != 0 && (*first..=*last).contains(n));
                if locked {
                    next.i_variable(*n) == prev.i_variable(*n)
                } else {
                    next.i_variable(*n) == assigned(cfg, *n, *v)
                }
            }
            _ => true,
        }),
    },
    Monitor {
        name: "an M-variable assignment or a memory write changes an I-variable whatever I41 holds",
        cite: "SRM p.57",
        sentence: "I41 does not prevent changes to an I-variable by means of an M-variable assignment or a direct memory write command.",
        check: Check::Event(|cfg, prev, ev, reply, next| match ev {
            Event::Command(HostCommand::WriteIMemory(n, v)) if running(prev) && reply == Reply::Ack => next.i_variable(*n) == assigned(cfg, *n, *v),
            _ => true,
        }),
    },
    Monitor {
        name: "after $$$*** the I-variables are the factory defaults",
        cite: "UM p.243",
        sentence: "(summary) $$$*** re-initializes the card: active memory takes the firmware's default I-variable values, and what was last saved stays in flash without being used.",
        check: Check::Event(|cfg, prev, ev, _, next| match ev {
            Event::Command(HostCommand::Reinitialize) if running(prev) => {
                (next.i8, next.i40, next.i41) == (cfg.factory.i8, cfg.factory.i40, cfg.factory.i41)
                    && next.other_i_variables.is_empty()
            }
            _ => true,
        }),
    },
    Monitor {
        name: "CHECKSUM reports the factory reference, whatever faults and checksum errors came since",
        cite: "UM p.217",
        sentence: "a reference register in memory (obtainable with the CHECKSUM command) ... Turbo PMACs shipped from the factory are preloaded with the correct reference value.",
        check: Check::Event(|_, prev, ev, reply, _| match ev {
            Event::Command(HostCommand::Checksum) if running(prev) => {
                reply == Reply::Hex(u32::from(crate::controller::ChecksumEngine::fresh().firmware_reference))
            }
            _ => true,
        }),
    },
    Monitor {
        name: "bit 22 once set stays set until reset or an explicit clear",
        cite: "SRM p.289",
        sentence: "It stays at 1 until the card is reset, or until this bit is manually changed to 0.",
        check: Check::Event(|_, prev, ev, _, next| {
            implies!(prev.status.rti_reentry && !next.status.rti_reentry, is_reset(ev) || matches!(ev, Event::ClearRtiReentry))
        }),
    },
    Monitor {
        name: "an RTI overrun sets bits 22 and 9",
        cite: "SRM p.289-290",
        sentence: "Bit 22 ... still executing when the next real-time interrupt came; bit 9 ... took more than one interrupt period.",
        // The words built only after an overrun: the checker runs this on every servo cycle.
        check: Check::Cycle(|cfg, _, report, next| {
            !report.rti_overrun || {
                let (x, _) = next.status_words(cfg);
                bit(x, cfg.layout.rti_reentry.1) && bit(x, cfg.layout.rti_warning.1)
            }
        }),
    },
    Monitor {
        name: "bit 20 is set after a servo cycle exactly when the servo work is more than the cycle holds",
        cite: "SRM p.289",
        sentence: "Bit 20 Servo Error: This bit is 1 if Turbo PMAC could not properly complete its servo routines. ... It is 0 if the servo operations have been completing properly.",
        // Work that fills the cycle exactly still completes: a configuration with such a load
        // (check.yaml `edges`) tells `>` from `>=`.
        check: Check::Cycle(|cfg, prev, _, next| {
            let work = u32::from(prev.load.motors) * u32::from(cfg.cpu.servo_units_per_motor);
            !running(prev) || next.status.servo_error == (work > u32::from(cfg.cpu.cycle_units))
        }),
    },
    Monitor {
        name: "PLC 0 starts only when the previous RTI tasks have completed",
        cite: "UM p.236",
        sentence: "PLC 0 and PLCC 0 will execute every real-time interrupt as long as the tasks from the previous RTI have been completed.",
        check: Check::Cycle(|_, prev, report, _| !report.rti_started || prev.rti_remaining == 0),
    },
    Monitor {
        name: "while the RTI tasks are unfinished the background gets no time",
        cite: "UM p.236",
        sentence: "In the time not taken by any of the higher-priority tasks, Turbo PMAC will be executing background tasks.",
        // A cycle that ends with RTI tasks (PLC 0, move planning) still to run gave them all
        // the time the servo update left, so none went to the background: a PLC 0 that fills
        // its RTI period starves the background (UM p.236, SRM p.42). Found missing by issue 34:
        // no check of the model check saw a background given PLC 0's time.
        check: Check::Cycle(|_, prev, _, next| {
            implies!(next.rti_remaining > 0, next.background_credit <= prev.background_credit)
        }),
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
                status_text_is_the_words(reply) && (x, y) == next.status_words(cfg)
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
            // The words are built only when the error has just appeared (every transition
            // runs this check).
            !(prev.checksum.error.is_none() && next.checksum.error == Some(ChecksumTarget::Firmware)) || {
                let (x, _) = next.status_words(cfg);
                bit(x, cfg.layout.checksum_error.1) && bit(x, cfg.layout.prom_checksum_active.1)
            }
        }),
    },
    // ------------------------------------------------------------ stop commands (UM p.217, p.319)
    Monitor {
        name: "after K the motor's amplifier is disabled and its output zero in the same servo cycle",
        cite: "UM p.319",
        sentence: "disables ... motors ... by opening the servo loops, forcing zero-value command outputs, and disabling the amplifiers (K: Begin Immed? Yes, UM p.217).",
        check: Check::Event(|cfg, prev, ev, reply, next| match motion(prev, ev) {
            Some(Motion::Motor(n, MotorCommand::Kill)) if n <= cfg.motion.motors && reply == Reply::Ack => {
                let m = &next.axes.motors()[usize::from(n) - 1];
                m.state == MotorState::Killed && !m.amplifier_enabled && m.output_zero
            }
            _ => true,
        }),
    },
    Monitor {
        name: "K is refused while the motor's coordinate system executes a program",
        cite: "UM p.319",
        sentence: "the motor-specific K kill command is not permitted when the motor is in a coordinate system that is executing a motion program. The program must first be halted.",
        check: Check::Event(|cfg, prev, ev, reply, next| match motion(prev, ev) {
            Some(Motion::Motor(n, MotorCommand::Kill)) if n <= cfg.motion.motors => {
                let executing = program(prev, cfg.motion.coordinate_system(n)).executing();
                implies!(executing, reply == Reply::Error(1) && next.axes == prev.axes)
            }
            _ => true,
        }),
    },
    Monitor {
        name: "after <CTRL-K> every motor is killed at once",
        cite: "UM p.319",
        sentence: "The <CTRL-K> kill-all command breaks into the executing trajectory immediately, and disables all motors.",
        check: Check::Event(|_, prev, ev, _, next| match motion(prev, ev) {
            Some(Motion::Global(GlobalCommand::KillAll)) => {
                next.axes.motors().iter().all(|m| m.state == MotorState::Killed && !m.amplifier_enabled && m.output_zero)
            }
            _ => true,
        }),
    },
    Monitor {
        name: "a killed motor does not move until it is re-enabled",
        cite: "UM p.319",
        sentence: "Motors will coast to a stop ... Although the program could be resumed after re-enabling the servo loops (MODEL: J/ re-enables, to closed loop at rest).",
        check: Check::Event(|_, prev, ev, _, next| {
            prev.axes.motors().iter().zip(next.axes.motors()).enumerate().all(|(k, (p, n))| {
                // `||` rather than `implies`: the command is looked at only for a motor that left Killed.
                !(p.state == MotorState::Killed && n.state != MotorState::Killed) || {
                    let reenabled = matches!(motion(prev, ev), Some(Motion::Motor(m, MotorCommand::JogStop)) if usize::from(m) == k + 1);
                    reenabled && n.state == MotorState::Closed
                }
            })
        }),
    },
    Monitor {
        name: "J/ begins immediately: a jogging motor decelerates at once, and no other motor changes",
        cite: "UM p.217",
        sentence: "J/: Scope Motor, Begin Immed? Yes, Decel Rate Ixx19-21.",
        check: Check::Event(|cfg, prev, ev, _, next| match motion(prev, ev) {
            Some(Motion::Motor(n, MotorCommand::JogStop)) if n >= 1 && n <= cfg.motion.motors => {
                let k = usize::from(n) - 1;
                let (p, m) = (&prev.axes.motors()[k], &next.axes.motors()[k]);
                implies!(p.state == MotorState::Jogging, m.state == MotorState::Decelerating && m.stop == Some(Stop::Jog))
                    && (0..prev.axes.motors().len()).filter(|j| *j != k).all(|j| prev.axes.motors()[j] == next.axes.motors()[j])
            }
            _ => true,
        }),
    },
    Monitor {
        name: "A begins immediately: no motor of the coordinate system runs its program or jogs after it",
        cite: "UM p.217",
        sentence: "A: Scope C.S., Begin Immed? Yes, Decel Rate Ixx15 (UM p.319: A breaks into the executing trajectory immediately).",
        check: Check::Event(|cfg, prev, ev, _, next| match motion(prev, ev) {
            Some(Motion::CoordinateSystem(cs, CsCommand::Abort)) => members(cfg, cs).all(|k| {
                let m = &next.axes.motors()[k];
                !matches!(m.state, MotorState::Program | MotorState::Jogging | MotorState::Holding)
            }),
            Some(Motion::Global(GlobalCommand::AbortAll)) => next
                .axes
                .motors()
                .iter()
                .all(|m| !matches!(m.state, MotorState::Program | MotorState::Jogging | MotorState::Holding)),
            _ => true,
        }),
    },
    Monitor {
        name: "A does not finish calculated moves: an executing program loses its lookahead",
        cite: "UM p.217",
        sentence: "A: Stop at Prog Pt? No, No easy restart (UM p.319: segments already in the lookahead buffer are discarded; they cannot be recovered).",
        check: Check::Event(|cfg, prev, ev, _, next| {
            let aborted = match motion(prev, ev) {
                Some(Motion::CoordinateSystem(cs, CsCommand::Abort)) => cs..=cs,
                Some(Motion::Global(GlobalCommand::AbortAll)) => 1..=prev.axes.programs().len() as u8,
                _ => return true,
            };
            aborted.into_iter().all(|cs| {
                implies!(program(prev, cs).executing(), program(next, cs) == Program::Lost)
                    && members(cfg, cs).all(|k| next.axes.motors()[k].stop != Some(Stop::Quit))
            })
        }),
    },
    Monitor {
        name: "Q does not begin immediately: the program's motors go on with their calculated moves",
        cite: "UM p.217",
        sentence: "Q: Begin Immed? No, Stop on Path? Yes, Finishes calculated moves.",
        check: Check::Event(|cfg, prev, ev, _, next| {
            let quit = match motion(prev, ev) {
                Some(Motion::CoordinateSystem(cs, CsCommand::Quit | CsCommand::EndOfMove)) => cs..=cs,
                Some(Motion::Global(GlobalCommand::QuitAll)) => 1..=prev.axes.programs().len() as u8,
                _ => return true,
            };
            quit.into_iter().all(|cs| {
                members(cfg, cs).all(|k| {
                    implies!(prev.axes.motors()[k].state == MotorState::Program, next.axes.motors()[k].state == MotorState::Program)
                }) && implies!(program(prev, cs) == Program::Running, program(next, cs) == Program::Running)
            })
        }),
    },
    Monitor {
        name: "Q and / stop at a program point",
        cite: "UM p.217",
        sentence: "Q: Stop at Prog Pt? Yes, Finishes calculated moves; /: Stop at Prog Pt? Yes, End of currently executing move.",
        check: Check::Cycle(|cfg, prev, _, next| {
            prev.axes.motors().iter().zip(next.axes.motors()).enumerate().all(|(k, (p, n))| {
                let ended = matches!(p.stop, Some(Stop::Quit | Stop::EndOfMove)) && n.stop.is_none() && !next.tripped();
                implies!(ended, n.state == MotorState::Closed && matches!(program(next, cs_of(cfg, k)), Program::AtPoint | Program::Running))
            }) && (1..=prev.axes.programs().len() as u8).all(|cs| {
                implies!(
                    program(prev, cs) == Program::Running && program(next, cs) != Program::Running,
                    program(next, cs) == Program::AtPoint,
                )
            })
        }),
    },
    Monitor {
        name: "H stops on the path: its motors end holding, and R can resume the program",
        cite: "UM p.217",
        sentence: "H: Stop on Path? Yes, Stop at Prog Pt? No, Decel Rate Isx95, Similar to %0 (SRM p.260: can be started up again with an R).",
        check: Check::Cycle(|cfg, prev, _, next| {
            prev.axes.motors().iter().zip(next.axes.motors()).enumerate().all(|(k, (p, n))| {
                implies!(
                    p.stop == Some(Stop::Hold) && n.stop.is_none() && !next.tripped(),
                    n.state == MotorState::Holding && program(next, cs_of(cfg, k)) == Program::Held,
                )
            })
        }),
    },
    Monitor {
        name: "a coordinate-system command acts only on the motors of its coordinate system",
        cite: "UM p.217",
        sentence: "Scope: C.S. (A, Q, /, H, \\).",
        check: Check::Event(|cfg, prev, ev, _, next| match motion(prev, ev) {
            Some(Motion::CoordinateSystem(cs, _)) => (0..prev.axes.motors().len())
                .filter(|k| cs_of(cfg, *k) != cs)
                .all(|k| prev.axes.motors()[k] == next.axes.motors()[k]),
            _ => true,
        }),
    },
    Monitor {
        name: "<CTRL-O> holds every running program and <CTRL-Q> quits each",
        cite: "SRM p.260",
        sentence: "This command causes all coordinate systems in Turbo PMAC to undergo a feed hold. It is equivalent to issuing the H command to each coordinate system.",
        check: Check::Event(|_, prev, ev, _, next| match motion(prev, ev) {
            Some(Motion::Global(GlobalCommand::HoldAll)) => next.axes.programs().iter().all(|p| *p != Program::Running),
            Some(Motion::Global(GlobalCommand::QuitAll)) => next
                .axes
                .motors()
                .iter()
                .all(|m| m.state != MotorState::Program || matches!(m.stop, Some(Stop::Quit | Stop::EndOfMove))),
            _ => true,
        }),
    },
    // ------------------------------------------------------------ the firmware's amplifier-fault kill (UM p.213)
    Monitor {
        name: "an amplifier fault kills the offending motor at the next background cycle and sets its fault status",
        cite: "UM p.213",
        sentence: "Turbo PMAC reacts just as for an amplifier fault error. The offending motor is killed ... Turbo PMAC sets the amplifier fault motor status bit. (UM p.237: the housekeeping's safety checks, amplifier fault among them, end each background cycle.)",
        check: Check::Event(|_, prev, ev, _, next| {
            let offending = |m: &crate::motion::Motor| m.state != MotorState::Killed && m.amplifier_fault;
            // MODEL: the check follows the PLC's scan; a motor the PLC's CMD^K killed first is
            // no longer enabled when the check comes, and is not an offending motor.
            let plc_fires = prev.axes.motors().iter().any(|m| m.state != MotorState::Killed && m.encoder_lost);
            !matches!(ev, Event::Background)
                || !prev.background_possible()
                || plc_fires
                || prev
                    .axes
                    .motors()
                    .iter()
                    .zip(next.axes.motors())
                    .all(|(p, n)| implies!(offending(p), n.state == MotorState::Killed && n.fault_status))
        }),
    },
    Monitor {
        name: "an amplifier fault kills no motor outside the offending motors' coordinate systems",
        cite: "UM p.213",
        sentence: "The offending motor is killed and possibly other motors as set by bits 21 and 22 of Ixx24.",
        // Unlike the encoder-loss PLC's CMD^K (UM p.214-215, every motor): on a background
        // cycle whose PLC scan kills nothing, a motor of another coordinate system keeps its
        // state. MODEL: Ixx24 bits 21-22 read as adding no motor outside the offending
        // motor's coordinate system.
        check: Check::Event(|cfg, prev, ev, _, next| {
            let plc_fires = prev.axes.motors().iter().any(|m| m.state != MotorState::Killed && m.encoder_lost);
            if !matches!(ev, Event::Background) || !prev.background_possible() || plc_fires {
                return true;
            }
            let motors = prev.axes.motors();
            let hit: Vec<u8> = (0..motors.len())
                .filter(|k| motors[*k].state != MotorState::Killed && motors[*k].amplifier_fault)
                .map(|k| cs_of(cfg, k))
                .collect();
            (0..motors.len())
                .filter(|k| !hit.contains(&cs_of(cfg, *k)))
                .all(|k| motors[k].state == next.axes.motors()[k].state)
        }),
    },
    Monitor {
        name: "the amplifier-fault status is set only by the fault kill and cleared only when the motor is re-enabled or the card reset",
        cite: "UM p.213",
        sentence: "Turbo PMAC sets the amplifier fault motor status bit. ... Both bits are cleared when the motor is re-enabled.",
        check: Check::Event(|_, prev, ev, _, next| {
            prev.axes.motors().iter().zip(next.axes.motors()).all(|(p, n)| match (p.fault_status, n.fault_status) {
                (false, true) => matches!(ev, Event::Background) && p.amplifier_fault && p.state != MotorState::Killed,
                (true, false) => n.state != MotorState::Killed || matches!(ev, Event::Reset(_)) || is_reset(ev),
                _ => true,
            })
        }),
    },
    // ------------------------------------------------------------ the encoder-loss PLC (UM p.214-215)
    Monitor {
        name: "a closed-loop motor whose encoder is lost has every motor killed at the next background cycle, its loss latched",
        cite: "UM p.214-215",
        sentence: "IF (Mtr1OpenLoop=0 AND Enc1LossIn=Lost) CMD^K ; Kill all motors / Mtr1EncLossStatus=1 (a compiled background PLC, which scans once per background cycle).",
        check: Check::Event(|_, prev, ev, _, next| {
            let fires = |m: &crate::motion::Motor| m.state != MotorState::Killed && m.encoder_lost;
            !matches!(ev, Event::Background)
                || !prev.background_possible()
                || !prev.axes.motors().iter().any(fires)
                || (next.axes.motors().iter().all(|n| n.state == MotorState::Killed)
                    && next.axes.programs().iter().all(|p| !p.executing())
                    && prev.axes.motors().iter().zip(next.axes.motors()).all(|(p, n)| implies!(fires(p), n.loss_status)))
        }),
    },
    Monitor {
        name: "the encoder-loss status is latched only by the PLC's scan in a background cycle",
        cite: "UM p.215",
        sentence: "These algorithms are best implemented in a compiled background PLC program, which scans ... once per background cycle.",
        check: Check::Event(|_, prev, ev, _, next| {
            // Outside a background cycle, no motor's status goes from clear to latched.
            matches!(ev, Event::Background) || prev.axes.motors().iter().zip(next.axes.motors()).all(|(p, n)| p.loss_status || !n.loss_status)
        }),
    },
    Monitor {
        name: "under the intended reading the PLC clears a latched loss once the motor is closed-loop with its encoder OK",
        cite: "UM p.215",
        sentence: "Logic to clear fault status: IF (Mtr1OpenLoop=0 AND Enc1LossIn=OK AND Mtr1EncLossStatus=...) Mtr1EncLossStatus=0 (facts s.6: the evident intent).",
        check: Check::Event(|cfg, prev, ev, _, next| {
            cfg.profile.choices.encoder_loss_clear != EncoderLossClear::Intent
                || !matches!(ev, Event::Background)
                || !prev.background_possible()
                || prev.axes.motors().iter().zip(next.axes.motors()).all(|(p, n)| {
                    implies!(p.loss_status && p.state != MotorState::Killed && !p.encoder_lost, !n.loss_status)
                })
        }),
    },
    Monitor {
        name: "under the literal reading a latched encoder loss stays latched until a reset",
        cite: "UM p.215",
        sentence: "IF (Mtr1OpenLoop=0 AND Enc1LossIn=OK AND Mtr1EncLossStatus=0) Mtr1EncLossStatus=0 (as printed, the branch needs the status already 0).",
        check: Check::Event(|cfg, prev, ev, _, next| {
            cfg.profile.choices.encoder_loss_clear != EncoderLossClear::Literal
                || is_reset(ev)
                || prev.axes.motors().iter().zip(next.axes.motors()).all(|(p, n)| implies!(p.loss_status, n.loss_status))
        }),
    },
];

#[cfg(test)]
mod tests {
    //! The monitors' helpers read what the sentences they serve say. A helper answering `true`
    //! or every motor would only make monitors lenient, which no property run can notice (a
    //! monitor that holds more often still holds): cargo-mutants found those survivors.
    use super::*;
    use crate::controller::TripCause;
    use pmacwd_specs::config::ModelConfig;
    use pmacwd_specs::Spec;

    fn config(name: &str) -> ModelConfig {
        let spec = Spec::embedded().unwrap();
        ModelConfig::from_spec(&spec, name, &spec.profiles.default_profile()).unwrap()
    }

    fn motion_config() -> ModelConfig {
        config("motion")
    }

    /// `implies!` reads as `!a || b`, `b` evaluated only when `a` holds (as a function it
    /// evaluated both, which the checker paid for on every transition and servo cycle).
    #[test]
    fn implies_evaluates_its_consequent_only_when_the_antecedent_holds() {
        let mut evaluated = 0;
        let mut consequent = |v: bool| {
            evaluated += 1;
            v
        };
        assert!(implies!(false, consequent(false)));
        assert!(implies!(true, consequent(true)));
        assert!(!implies!(true, consequent(false)));
        assert_eq!(evaluated, 2, "the consequent is evaluated once per true antecedent");
    }

    /// The event check of the monitor named `name`.
    fn event_check(name: &str) -> fn(&ModelConfig, &Controller, &Event, Reply, &Controller) -> bool {
        match MONITORS.iter().find(|m| m.name == name).map(|m| &m.check) {
            Some(Check::Event(f)) => *f,
            _ => panic!("no event monitor named {name:?}"),
        }
    }

    /// The cycle check of the monitor named `name`.
    fn cycle_check(name: &str) -> fn(&ModelConfig, &Controller, CycleReport, &Controller) -> bool {
        match MONITORS.iter().find(|m| m.name == name).map(|m| &m.check) {
            Some(Check::Cycle(f)) => *f,
            _ => panic!("no cycle monitor named {name:?}"),
        }
    }

    /// `prev` after `ev` as the model takes it: the state after and the reply.
    fn step(cfg: &ModelConfig, prev: &Controller, ev: &Event) -> (Controller, Reply) {
        let mut next = prev.clone();
        let reply = next.apply(cfg, ev);
        (next, reply)
    }

    fn command(text: &str) -> Event {
        Event::Command(HostCommand::parse(text).expect("command parses"))
    }

    /// `lockout` (I130 and I5100 written under I41 = 0, 1 and 3, SRM p.57) after power-on,
    /// running, with I41 = `i41`.
    fn lockout_card(cfg: &ModelConfig, i41: u8) -> Controller {
        let mut c = Controller::power_on(cfg);
        assert!(running(&c), "the card runs after power-on");
        c.i41 = i41;
        c
    }

    // The monitors below are each handed the model's own transition, which must hold, and the
    // same transition with the reply or the state after changed the way the sentence forbids,
    // which must fire. A monitor whose guard is weakened until it checks nothing still holds on
    // every transition of a correct model, so only such a hand-made violation shows it
    // (cargo-mutants: the survivors of monitor.rs shards 2/8 and 3/8).

    #[test]
    fn sentence_srm_57_a_locked_i_variable_write_is_acknowledged_not_refused_with_an_error() {
        // SRM p.57: with the controlling I41 bit set, "the command is ignored (no error is
        // generated)". I41 = 1 locks I100-I4899.
        let cfg = config("lockout");
        let check = event_check("a locked I-variable write is ignored without an error");
        let prev = lockout_card(&cfg, 1);
        let ev = command("I130=1");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!(reply, Reply::Ack);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's locked write holds");
        assert!(!check(&cfg, &prev, &ev, Reply::Error(3), &next), "a locked write answered ERR003 fires");
        // An unlocked write refused for its value is no locked write: not this monitor's business.
        let refused = command("I41=16");
        let (next, reply) = step(&cfg, &prev, &refused);
        assert_eq!(reply, Reply::Error(3));
        assert!(check(&cfg, &prev, &refused, reply, &next));
    }

    #[test]
    fn sentence_srm_57_i41_itself_in_no_locked_set_takes_every_value_of_its_range() {
        // SRM p.57: the table of the sets each bit of I41 controls has no I41 in it, so I41 =
        // 3 takes effect even with every bit set; I41 = 16, outside its range (0-15), is refused
        // and changes nothing.
        let cfg = config("lockout");
        assert_eq!(cfg.i41_range, (0, 15));
        let check = event_check("I41 itself is never locked out");
        let prev = lockout_card(&cfg, 15);
        for text in ["I41=3", "I41=0", "I41=15"] {
            let ev = command(text);
            let (next, reply) = step(&cfg, &prev, &ev);
            assert_eq!(reply, Reply::Ack, "{text}");
            assert!(check(&cfg, &prev, &ev, reply, &next), "{text}: the model's write holds");
            let mut ignored = next.clone();
            ignored.i41 = if text == "I41=0" { 1 } else { 0 };
            assert!(!check(&cfg, &prev, &ev, reply, &ignored), "{text} ignored fires");
        }
        let ev = command("I41=16");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!((reply, next.i41), (Reply::Error(3), 15));
        assert!(check(&cfg, &prev, &ev, reply, &next), "an out-of-range I41 refused holds");
    }

    #[test]
    fn under_um_243_s_modulo_an_out_of_range_write_that_rolls_over_holds_and_one_stored_as_sent_fires() {
        // UM p.243: I41=16 is no error and assigns 16 modulo 16 = 0 (the reading
        // out_of_range_assignment: modulo). The monitors of an acknowledged write judge the
        // value rolled over, not the one sent; under `error` the same write is refused.
        let mut cfg = config("lockout");
        cfg.profile.choices.out_of_range_assignment = pmacwd_specs::profiles::OutOfRangeAssignment::Modulo;
        let prev = lockout_card(&cfg, 15);
        let ev = command("I41=16");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!((reply, next.i41), (Reply::Ack, 0));
        for name in ["I41 itself is never locked out", "an I-variable write outside every locked range takes effect"] {
            let check = event_check(name);
            assert!(check(&cfg, &prev, &ev, reply, &next), "{name}: the rolled-over write holds");
            let mut kept = next.clone();
            kept.i41 = 15;
            assert!(!check(&cfg, &prev, &ev, reply, &kept), "{name}: a write that changed nothing fires");
        }
        let memory = command("<MEMORY-WRITE I40=65537>");
        let (next, reply) = step(&cfg, &prev, &memory);
        assert_eq!((reply, next.i40), (Reply::Ack, 1));
        let check = event_check("an M-variable assignment or a memory write changes an I-variable whatever I41 holds");
        assert!(check(&cfg, &prev, &memory, reply, &next), "a memory write rolled over holds");
    }

    #[test]
    fn sentence_srm_57_a_write_outside_every_locked_set_takes_effect() {
        // SRM p.57: "each bit independently controls access to a set of I-variables": with I41
        // = 1 (I100-I4899 locked), I5100 (bit 1's set) is written.
        let cfg = config("lockout");
        let check = event_check("an I-variable write outside every locked range takes effect");
        let prev = lockout_card(&cfg, 1);
        let ev = command("I5100=1");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!((reply, next.i_variable(5100)), (Reply::Ack, Some(1)));
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's write holds");
        let mut ignored = next.clone();
        ignored.other_i_variables.remove(&5100);
        assert!(!check(&cfg, &prev, &ev, reply, &ignored), "an unlocked write ignored fires");
        // The locked write that changes nothing is the lockout's, not a violation of this one.
        let locked = command("I130=1");
        let (next, reply) = step(&cfg, &prev, &locked);
        assert_eq!(next.i_variable(130), None);
        assert!(check(&cfg, &prev, &locked, reply, &next));
    }

    #[test]
    fn sentence_srm_57_a_memory_write_changes_a_locked_i_variable_and_a_refused_one_changes_nothing() {
        // SRM p.57: "I41 does not prevent changes to an I-variable by means of an M-variable
        // assignment or a direct memory write command." The check is of an acknowledged write;
        // a memory write refused for its value (I41 = 16, MODEL: ERR003) and one sent to a
        // tripped card (UM p.215: no answer) leave the value as it was, and hold.
        let cfg = config("lockout");
        let check = event_check("an M-variable assignment or a memory write changes an I-variable whatever I41 holds");
        let prev = lockout_card(&cfg, 1);
        let ev = command("<MEMORY-WRITE I130=2>");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!((reply, next.i_variable(130)), (Reply::Ack, Some(2)));
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's memory write holds");
        assert!(!check(&cfg, &prev, &ev, reply, &prev), "a memory write stopped by I41 fires");
        let refused = command("<MEMORY-WRITE I41=16>");
        let (next, reply) = step(&cfg, &prev, &refused);
        assert_eq!((reply, next.i41), (Reply::Error(3), 1));
        assert!(check(&cfg, &prev, &refused, reply, &next), "a refused memory write holds");
        let mut tripped = prev.clone();
        tripped.trip = Some(TripCause::StrobeTimeout);
        let (next, reply) = step(&cfg, &tripped, &ev);
        assert_eq!((reply, next.i_variable(130)), (Reply::Silence, None));
        assert!(check(&cfg, &tripped, &ev, reply, &next), "a tripped card's silence holds");
    }

    #[test]
    fn sentence_um_243_dollar_dollar_dollar_stars_leaves_every_i_variable_at_its_factory_default() {
        // UM p.243 (summary): re-initialization puts the firmware's default I-variable values
        // in active memory. `lockout` saves I8 = 1 and I40 = 3, the factories are 2 and 0.
        let cfg = config("lockout");
        assert_ne!((cfg.saved.i8, cfg.saved.i40), (cfg.factory.i8, cfg.factory.i40));
        let check = event_check("after $$$*** the I-variables are the factory defaults");
        let mut prev = lockout_card(&cfg, 3);
        prev.other_i_variables.insert(5100, 1);
        let ev = command("$$$***");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's re-initialization holds");
        let mut kept_i40 = next.clone();
        kept_i40.i40 = cfg.saved.i40;
        assert!(!check(&cfg, &prev, &ev, reply, &kept_i40), "I40 left at its saved value fires");
        let mut kept_other = next.clone();
        kept_other.other_i_variables.insert(5100, 1);
        assert!(!check(&cfg, &prev, &ev, reply, &kept_other), "I5100 left as written fires");
        // A tripped card does nothing with the command (UM p.215), and keeps its values.
        let mut tripped = prev.clone();
        tripped.trip = Some(TripCause::StrobeTimeout);
        let (next, reply) = step(&cfg, &tripped, &ev);
        assert_eq!((reply, next.i41), (Reply::Silence, 3));
        assert!(check(&cfg, &tripped, &ev, reply, &next), "a tripped card's silence holds");
    }

    #[test]
    fn sentence_um_217_checksum_reports_the_factory_reference_after_a_firmware_fault() {
        // UM p.217: the reference register is "obtainable with the CHECKSUM command"; "Turbo
        // PMACs shipped from the factory are preloaded with the correct reference value". A
        // corrupted firmware changes what is summed, not the reference.
        let cfg = config("lockout");
        let check =
            event_check("CHECKSUM reports the factory reference, whatever faults and checksum errors came since");
        let mut prev = lockout_card(&cfg, 0);
        prev.apply(&cfg, &Event::ChecksumFault(ChecksumTarget::Firmware));
        let ev = command("CHECKSUM");
        let (next, reply) = step(&cfg, &prev, &ev);
        let reference = u32::from(crate::controller::ChecksumEngine::fresh().firmware_reference);
        assert_eq!(reply, Reply::Hex(reference));
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's reply holds");
        let corrupted = Reply::Hex(u32::from(prev.checksum.firmware));
        assert_ne!(corrupted, reply);
        assert!(!check(&cfg, &prev, &ev, corrupted, &next), "the corrupted firmware's sum as the reply fires");
    }

    #[test]
    fn sentence_srm_289_an_rti_overrun_sets_both_bit_22_and_bit_9() {
        // SRM p.289-290: bit 22, the RTI still executing when the next one came; bit 9, the RTI
        // took more than one period. An overrun sets both, not just one of them.
        let cfg = config("lockout");
        let check = cycle_check("an RTI overrun sets bits 22 and 9");
        let prev = lockout_card(&cfg, 0);
        let overrun = CycleReport { rti_started: false, rti_overrun: true, strobed: false };
        let with = |reentry: bool, warning: bool| {
            let mut next = prev.clone();
            next.status.rti_reentry = reentry;
            next.status.rti_warning = warning;
            next
        };
        assert!(check(&cfg, &prev, overrun, &with(true, true)));
        assert!(!check(&cfg, &prev, overrun, &with(true, false)), "bit 22 without bit 9 fires");
        assert!(!check(&cfg, &prev, overrun, &with(false, true)), "bit 9 without bit 22 fires");
        assert!(check(&cfg, &prev, CycleReport::default(), &with(false, false)), "no overrun, no bits");
    }

    #[test]
    fn sentence_um_215_a_background_cycle_that_runs_reloads_the_counter_from_i40() {
        // UM p.215: "At the end of each background cycle, the CPU resets the counter value to
        // a maximum value set by variable I40". `lockout` has I40 = 3 and a background cycle
        // costing 3 units; with none of them had yet, no background cycle ends.
        let cfg = config("lockout");
        let check = event_check("a background cycle reloads the counter from I40");
        let mut prev = lockout_card(&cfg, 0);
        prev.counter = 1;
        prev.background_credit = u32::from(prev.load.background_units);
        assert!(prev.background_possible());
        let ev = Event::Background;
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!(next.counter, 3);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's reload holds");
        assert!(!check(&cfg, &prev, &ev, reply, &prev), "a background cycle that leaves the counter fires");
        let mut starved = prev.clone();
        starved.background_credit = 0;
        let (next, reply) = step(&cfg, &starved, &ev);
        assert_eq!(next.counter, 1);
        assert!(check(&cfg, &starved, &ev, reply, &next), "no background cycle possible, no reload: holds");
    }

    #[test]
    fn sentence_um_217_after_a_checksum_error_neither_checksum_moves_on() {
        // UM p.217: after a checksum error the card "stops performing any program or firmware
        // checksum operations": the area under check and the error stay as they are until a
        // reset.
        let cfg = config("lockout");
        let check = event_check("a checksum error stops both checksums");
        let mut prev = lockout_card(&cfg, 0);
        prev.checksum.error = Some(ChecksumTarget::Firmware);
        prev.background_credit = u32::from(prev.load.background_units);
        let ev = Event::Background;
        let (next, reply) = step(&cfg, &prev, &ev);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's background cycle holds");
        let mut moved_on = next.clone();
        moved_on.checksum.area = next.checksum.area.other();
        assert_eq!(moved_on.checksum.error, prev.checksum.error);
        assert!(!check(&cfg, &prev, &ev, reply, &moved_on), "the other area checked after the error fires");
        let mut cleared = next.clone();
        cleared.checksum.error = None;
        assert!(!check(&cfg, &prev, &ev, reply, &cleared), "the error forgotten without a reset fires");
    }

    #[test]
    fn sentence_srm_289_the_status_reply_is_the_words_of_the_state_after() {
        // SRM p.289: "Turbo PMAC returns twelve characters, representing two status words":
        // the words of X:$000006 and Y:$000006, not any other two.
        let cfg = config("lockout");
        let check = event_check("the ??? reply is twelve hex characters, first word first");
        let prev = lockout_card(&cfg, 0);
        let ev = command("???");
        let (next, reply) = step(&cfg, &prev, &ev);
        let Reply::Status { x, y } = reply else { panic!("??? answers the status words, not {reply:?}") };
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's reply holds");
        for wrong in
            [Reply::Status { x: x ^ (1 << 22), y }, Reply::Status { x, y: y ^ 1 }, Reply::Status { x: y, y: x }]
        {
            if wrong != reply {
                assert!(!check(&cfg, &prev, &ev, wrong, &next), "{wrong:?} for the words ({x:06X}, {y:06X}) fires");
            }
        }
    }

    /// `cfg`'s card after power-on and `commands`, each acknowledged.
    fn card_after(cfg: &ModelConfig, commands: &[&str]) -> Controller {
        let mut c = Controller::power_on(cfg);
        for text in commands {
            assert_eq!(c.apply(cfg, &command(text)), Reply::Ack, "{text}");
        }
        c
    }

    /// `prev` after one servo cycle as the model takes it: the report and the state after.
    fn cycle(cfg: &ModelConfig, prev: &Controller) -> (CycleReport, Controller) {
        let mut next = prev.clone();
        let report = next.servo_cycle(cfg);
        (report, next)
    }

    /// `c` tripped, its motor 1 killed (UM p.215: the Servo ICs held in reset).
    fn tripped_killing_motor_1(c: &Controller) -> Controller {
        let mut t = c.clone();
        t.trip = Some(TripCause::StrobeTimeout);
        let m = &mut t.axes.motors_mut()[0];
        (m.state, m.stop, m.stop_cycles, m.amplifier_enabled, m.output_zero) =
            (MotorState::Killed, None, 0, false, true);
        t
    }

    /// `motion` with motor 1 running &1's program (B, R) and motor 2 jogging, both enabled (J/).
    fn moving_card(cfg: &ModelConfig) -> Controller {
        let c = card_after(cfg, &["#1J/", "#2J/", "&1B", "&1R", "#2J+"]);
        assert_eq!((c.axes.motors()[0].state, c.axes.motors()[1].state), (MotorState::Program, MotorState::Jogging));
        assert_eq!(program(&c, 1), Program::Running);
        c
    }

    #[test]
    fn sentence_srm_289_a_running_card_in_bootstrap_mode_answers_bootstrap_prom() {
        // SRM p.289: "If the Turbo PMAC is in bootstrap mode ... its response to this command
        // will simply be BOOTSTRAP PROM", not the status words; a tripped card answers nothing.
        let cfg = config("lockout");
        let check = event_check("a card in bootstrap mode answers ??? with BOOTSTRAP PROM");
        let mut prev = lockout_card(&cfg, 0);
        prev.bootstrap = true;
        let ev = command("???");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!(reply, Reply::Bootstrap);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's reply holds");
        let (x, y) = prev.status_words(&cfg);
        assert!(!check(&cfg, &prev, &ev, Reply::Status { x, y }, &next), "the status words from a bootstrap card fire");
        let mut tripped = prev.clone();
        tripped.trip = Some(TripCause::StrobeTimeout);
        let (next, reply) = step(&cfg, &tripped, &ev);
        assert_eq!(reply, Reply::Silence);
        assert!(check(&cfg, &tripped, &ev, reply, &next), "a tripped card's silence holds");
    }

    #[test]
    fn sentence_srm_289_the_dpram_and_flash_bits_each_change_only_at_a_reset() {
        // SRM p.289: bit 11 reports the DPRAM check "at power-up/reset", bit 10 the flash read
        // "on board reset": between resets neither moves, whatever the other does.
        let cfg = config("lockout");
        let check = event_check("the DPRAM and flash error bits change only at a reset");
        let prev = lockout_card(&cfg, 0);
        let ev = command("???");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's ??? holds");
        let mut flash = next.clone();
        flash.status.flash_error = true;
        assert!(!check(&cfg, &prev, &ev, reply, &flash), "bit 10 set by ??? fires");
        let mut dpram = next.clone();
        dpram.status.dpram_error = true;
        assert!(!check(&cfg, &prev, &ev, reply, &dpram), "bit 11 set by ??? fires");
        let reset = Event::Reset(pmacwd_specs::check::ResetEvent {
            kind: pmacwd_specs::check::ResetKind::Init,
            dpram_fault: false,
            flash_fault: true,
            bootstrap: false,
        });
        let (next, reply) = step(&cfg, &prev, &reset);
        assert!(next.status.flash_error);
        assert!(check(&cfg, &prev, &reset, reply, &next), "a reset that finds a flash error holds");
    }

    #[test]
    fn sentence_um_215_a_supply_below_the_minimum_trips_and_one_at_or_above_it_does_not() {
        // UM p.215: "If the supply voltage is below this value, the circuit's relay will trip
        // and the card will shut down." Below, not at: a supply exactly at the minimum, and a
        // good one, leave the card running, and the monitor must accept that.
        let cfg = config("lockout");
        let check = event_check("a supply below the minimum trips the card at once");
        let prev = lockout_card(&cfg, 0);
        let min = cfg.supply_min_millivolts;
        let low = Event::Supply { millivolts: min - 1 };
        let (next, reply) = step(&cfg, &prev, &low);
        assert!(next.tripped());
        assert!(check(&cfg, &prev, &low, reply, &next), "the model's trip holds");
        assert!(!check(&cfg, &prev, &low, reply, &prev), "a card running on below the minimum fires");
        for mv in [min, min + 1, 5000] {
            let ev = Event::Supply { millivolts: mv };
            let (next, reply) = step(&cfg, &prev, &ev);
            assert!(!next.tripped(), "{mv} mV");
            assert!(check(&cfg, &prev, &ev, reply, &next), "{mv} mV, running on: holds");
        }
    }

    #[test]
    fn sentence_um_217_a_firmware_checksum_error_shows_bits_12_and_13_of_x6() {
        // UM p.217: on a firmware checksum error "it sets global status bits (bits 12 and 13
        // of X:$000006 ...)". The model builds the words from `status.yaml`'s positions; a
        // layout that moved either bit out of X:$000006 (a wrong `status.yaml`) must fire, as
        // must one that moved both.
        use pmacwd_specs::status::WordId;
        let cfg = config("lockout");
        let check = event_check("a firmware checksum error sets bits 12 and 13");
        let mut prev = lockout_card(&cfg, 0);
        prev.apply(&cfg, &Event::ChecksumFault(ChecksumTarget::Firmware));
        prev.background_credit = u32::from(prev.load.background_units);
        let ev = Event::Background;
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!(next.checksum.error, Some(ChecksumTarget::Firmware), "a pass of one background cycle finds it");
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's words hold");
        let moved = |bit13: bool, bit12: bool| {
            let mut wrong = cfg.clone();
            if bit13 {
                wrong.layout.checksum_error.0 = WordId::Y;
            }
            if bit12 {
                wrong.layout.prom_checksum_active.0 = WordId::Y;
            }
            wrong
        };
        for (bit13, bit12) in [(true, false), (false, true), (true, true)] {
            let wrong = moved(bit13, bit12);
            assert!(!check(&wrong, &prev, &ev, reply, &next), "bit 13 moved {bit13}, bit 12 moved {bit12}: fires");
        }
    }

    #[test]
    fn sentence_um_319_after_k_the_motor_is_killed_and_no_other_motor_is_looked_at() {
        // UM p.319: K disables the motor "by opening the servo loops, forcing zero-value
        // command outputs, and disabling the amplifiers", at once (UM p.217: K begins
        // immediately). `motion`: motor 2 keeps jogging, it is not the one killed.
        let cfg = config("motion");
        let check =
            event_check("after K the motor's amplifier is disabled and its output zero in the same servo cycle");
        let prev = card_after(&cfg, &["#1J/", "#2J/", "#2J+"]);
        let ev = command("#1K");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!((reply, next.axes.motors()[1].state), (Reply::Ack, MotorState::Jogging));
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's kill holds");
        let half = |f: fn(&mut crate::motion::Motor)| {
            let mut n = next.clone();
            f(&mut n.axes.motors_mut()[0]);
            n
        };
        for (what, n) in [
            ("still closed loop", half(|m| m.state = MotorState::Closed)),
            ("amplifier on", half(|m| m.amplifier_enabled = true)),
            ("output not zero", half(|m| m.output_zero = false)),
        ] {
            assert!(!check(&cfg, &prev, &ev, reply, &n), "K leaving motor 1 {what} fires");
        }
        // K refused while &1 runs its program (UM p.319) leaves the motor: holds here.
        let running = moving_card(&cfg);
        let (next, reply) = step(&cfg, &running, &ev);
        assert_eq!((reply, next.axes.motors()[0].state), (Reply::Error(1), MotorState::Program));
        assert!(check(&cfg, &running, &ev, reply, &next), "a refused K holds");
        // K to a motor the card does not have (MODEL: Ixx00 = 0) is acknowledged and does
        // nothing; the monitor does not look for a motor 3.
        let ev3 = command("#3K");
        let (next, reply) = step(&cfg, &prev, &ev3);
        assert_eq!((reply, &next), (Reply::Ack, &prev));
        assert!(check(&cfg, &prev, &ev3, reply, &next), "K to a motor not configured holds");
    }

    #[test]
    fn sentence_um_319_k_is_refused_while_the_program_of_its_coordinate_system_executes() {
        // UM p.319: "the motor-specific K kill command is not permitted when the motor is in a
        // coordinate system that is executing a motion program": ERR001, nothing changed.
        let cfg = config("motion");
        let check = event_check("K is refused while the motor's coordinate system executes a program");
        let prev = moving_card(&cfg);
        let ev = command("#1K");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!(reply, Reply::Error(1));
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's refusal holds");
        let mut killed = next.clone();
        killed.axes.motors_mut()[0].state = MotorState::Killed;
        assert!(!check(&cfg, &prev, &ev, Reply::Ack, &killed), "K obeyed fires");
        assert!(!check(&cfg, &prev, &ev, Reply::Error(1), &killed), "K refused but obeyed fires");
        assert!(!check(&cfg, &prev, &ev, Reply::Ack, &next), "K acknowledged, nothing done, fires");
        // Outside a program, K is allowed: motor 2 (in &2, no program) is killed.
        let ev2 = command("#2K");
        let (next, reply) = step(&cfg, &prev, &ev2);
        assert_eq!((reply, next.axes.motors()[1].state), (Reply::Ack, MotorState::Killed));
        assert!(check(&cfg, &prev, &ev2, reply, &next), "K outside a program holds");
        // A motor the card does not have (MODEL: Ixx00 = 0) is in no running program: K is
        // acknowledged and does nothing, and that holds.
        let ev3 = command("#3K");
        let (next, reply) = step(&cfg, &prev, &ev3);
        assert_eq!((reply, &next), (Reply::Ack, &prev));
        assert!(check(&cfg, &prev, &ev3, reply, &next), "K to a motor not configured holds");
    }

    #[test]
    fn sentence_um_319_ctrl_k_kills_every_motor() {
        // UM p.319: "The <CTRL-K> kill-all command breaks into the executing trajectory
        // immediately, and disables all motors."
        let cfg = config("motion");
        let check = event_check("after <CTRL-K> every motor is killed at once");
        let prev = moving_card(&cfg);
        let ev = command("<CTRL-K>");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's kill-all holds");
        for k in 0..2 {
            let mut n = next.clone();
            n.axes.motors_mut()[k].state = MotorState::Closed;
            assert!(!check(&cfg, &prev, &ev, reply, &n), "motor {} left closed loop fires", k + 1);
            let mut n = next.clone();
            n.axes.motors_mut()[k].amplifier_enabled = true;
            assert!(!check(&cfg, &prev, &ev, reply, &n), "motor {}'s amplifier left on fires", k + 1);
            let mut n = next.clone();
            n.axes.motors_mut()[k].output_zero = false;
            assert!(!check(&cfg, &prev, &ev, reply, &n), "motor {}'s output left driven fires", k + 1);
        }
    }

    #[test]
    fn sentence_um_319_a_killed_motor_moves_again_only_through_its_own_j_slash() {
        // UM p.319: killed motors coast; the program "could be resumed after re-enabling the
        // servo loops" (MODEL: J/ re-enables a motor, to closed loop at rest). A killed motor
        // leaves Killed only by its own J/, and then only to closed loop at rest.
        let cfg = config("motion");
        let check = event_check("a killed motor does not move until it is re-enabled");
        let prev = Controller::power_on(&cfg);
        assert!(prev.axes.motors().iter().all(|m| m.state == MotorState::Killed));
        let j1 = command("#1J/");
        let (next, reply) = step(&cfg, &prev, &j1);
        assert_eq!(next.axes.motors()[0].state, MotorState::Closed);
        assert!(check(&cfg, &prev, &j1, reply, &next), "the model's J/ holds");
        let mut jogging = next.clone();
        jogging.axes.motors_mut()[0].state = MotorState::Jogging;
        assert!(!check(&cfg, &prev, &j1, reply, &jogging), "J/ leaving motor 1 jogging fires");
        let j2 = command("#2J/");
        assert!(!check(&cfg, &prev, &j2, reply, &next), "motor 1 re-enabled by motor 2's J/ fires");
        let jog = command("#1J+");
        let (stays, reply) = step(&cfg, &prev, &jog);
        assert_eq!(stays.axes.motors()[0].state, MotorState::Killed);
        assert!(check(&cfg, &prev, &jog, reply, &stays), "a jog of a killed motor that stays killed holds");
        assert!(!check(&cfg, &prev, &jog, reply, &jogging), "a killed motor jogged by J+ fires");
        // A closed-loop motor that starts to jog was never killed: holds.
        let enabled = next;
        let (jogs, reply) = step(&cfg, &enabled, &jog);
        assert_eq!(jogs.axes.motors()[0].state, MotorState::Jogging);
        assert!(check(&cfg, &enabled, &jog, reply, &jogs), "J+ of an enabled motor holds");
    }

    #[test]
    fn sentence_um_217_a_begins_immediately_so_no_motor_of_the_system_goes_on() {
        // UM p.217: A, "Begin Immed? Yes" (UM p.319: A "breaks into the executing trajectory
        // immediately"); <CTRL-A> is A for every coordinate system. Decelerating is allowed.
        let cfg = config("motion");
        let check =
            event_check("A begins immediately: no motor of the coordinate system runs its program or jogs after it");
        let prev = moving_card(&cfg);
        let a1 = command("&1A");
        let (next, reply) = step(&cfg, &prev, &a1);
        assert_eq!(next.axes.motors()[0].state, MotorState::Decelerating);
        assert!(check(&cfg, &prev, &a1, reply, &next), "the model's A holds");
        for state in [MotorState::Program, MotorState::Jogging, MotorState::Holding] {
            let mut n = next.clone();
            n.axes.motors_mut()[0].state = state;
            assert!(!check(&cfg, &prev, &a1, reply, &n), "motor 1 {state:?} after &1A fires");
        }
        let all = command("<CTRL-A>");
        let (next, reply) = step(&cfg, &prev, &all);
        assert!(next.axes.motors().iter().all(|m| m.state == MotorState::Decelerating));
        assert!(check(&cfg, &prev, &all, reply, &next), "the model's <CTRL-A> holds");
        for state in [MotorState::Program, MotorState::Jogging, MotorState::Holding] {
            let mut n = next.clone();
            n.axes.motors_mut()[1].state = state;
            assert!(!check(&cfg, &prev, &all, reply, &n), "motor 2 {state:?} after <CTRL-A> fires");
        }
    }

    #[test]
    fn sentence_um_217_a_discards_the_lookahead_of_an_executing_program() {
        // UM p.217: A, "Stop at Prog Pt? No, No easy restart" (UM p.319: the lookahead is
        // discarded): the program is lost and no motor of the system finishes a move as Q would.
        let cfg = config("motion");
        let check = event_check("A does not finish calculated moves: an executing program loses its lookahead");
        let prev = moving_card(&cfg);
        for text in ["&1A", "<CTRL-A>"] {
            let ev = command(text);
            let (next, reply) = step(&cfg, &prev, &ev);
            assert_eq!(program(&next, 1), Program::Lost, "{text}");
            assert!(check(&cfg, &prev, &ev, reply, &next), "the model's {text} holds");
            for kept in [Program::AtPoint, Program::Running, Program::Held] {
                let mut n = next.clone();
                n.axes.programs_mut()[0] = kept;
                assert!(!check(&cfg, &prev, &ev, reply, &n), "{text} leaving &1's program {kept:?} fires");
            }
            let mut finishing = next.clone();
            finishing.axes.motors_mut()[0].stop = Some(Stop::Quit);
            assert!(!check(&cfg, &prev, &ev, reply, &finishing), "{text} finishing motor 1's move as Q does fires");
        }
        // A with no program executing: nothing is lost, and that holds.
        let idle = card_after(&cfg, &["#1J/", "&1B"]);
        let ev = command("&1A");
        let (next, reply) = step(&cfg, &idle, &ev);
        assert_eq!(program(&next, 1), Program::AtPoint);
        assert!(check(&cfg, &idle, &ev, reply, &next), "A on a program at a point holds");
    }

    #[test]
    fn sentence_um_217_q_and_slash_let_the_program_s_motors_finish_their_moves() {
        // UM p.217: Q, "Begin Immed? No ... Finishes calculated moves"; / ends at the "End of
        // currently executing move": the motors stay in the program, the program runs on.
        let cfg = config("motion");
        let check = event_check("Q does not begin immediately: the program's motors go on with their calculated moves");
        let prev = moving_card(&cfg);
        for text in ["&1Q", "&1/", "<CTRL-Q>"] {
            let ev = command(text);
            let (next, reply) = step(&cfg, &prev, &ev);
            assert_eq!(next.axes.motors()[0].state, MotorState::Program, "{text}");
            assert!(check(&cfg, &prev, &ev, reply, &next), "the model's {text} holds");
            let mut stopped = next.clone();
            stopped.axes.motors_mut()[0].state = MotorState::Decelerating;
            assert!(!check(&cfg, &prev, &ev, reply, &stopped), "{text} stopping motor 1 at once fires");
            let mut ended = next.clone();
            ended.axes.programs_mut()[0] = Program::AtPoint;
            assert!(!check(&cfg, &prev, &ev, reply, &ended), "{text} ending the program at once fires");
        }
        // Q on a system with no running program (&2: motor 2 jogs, no program): holds.
        let ev = command("&2Q");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert!(check(&cfg, &prev, &ev, reply, &next), "Q with no program running holds");
    }

    #[test]
    fn sentence_um_217_q_and_slash_end_at_a_program_point_with_the_motors_at_rest() {
        // UM p.217: Q and / "Stop at Prog Pt? Yes": when the last calculated move is done the
        // motor is closed loop at rest and the program stands at a point, ready for R.
        let cfg = config("motion");
        let check = cycle_check("Q and / stop at a program point");
        let mut prev = moving_card(&cfg);
        prev.apply_with_decel(&cfg, &command("&1Q"), 1);
        assert_eq!(prev.axes.motors()[0].stop, Some(Stop::Quit));
        let (report, next) = cycle(&cfg, &prev);
        assert_eq!((next.axes.motors()[0].state, program(&next, 1)), (MotorState::Closed, Program::AtPoint));
        assert!(check(&cfg, &prev, report, &next), "the model's end of Q holds");
        let mut held = next.clone();
        held.axes.motors_mut()[0].state = MotorState::Holding;
        assert!(!check(&cfg, &prev, report, &held), "Q ending in a hold fires");
        for wrong in [Program::Held, Program::Lost] {
            let mut n = next.clone();
            n.axes.programs_mut()[0] = wrong;
            assert!(!check(&cfg, &prev, report, &n), "Q ending with the program {wrong:?} fires");
        }
        // A cycle in which the program runs on and motor 2 jogs, without a stop: holds.
        let running = moving_card(&cfg);
        let (report, next) = cycle(&cfg, &running);
        assert_eq!(program(&next, 1), Program::Running);
        assert!(check(&cfg, &running, report, &next), "a running program's cycle holds");
        // A cycle that trips the card with the Q under way kills the motor: no program point
        // is reached, and that holds.
        let after = tripped_killing_motor_1(&prev);
        assert!(check(&cfg, &prev, report, &after), "a trip during the Q holds");
    }

    #[test]
    fn sentence_um_217_h_ends_with_its_motors_holding_and_the_program_held() {
        // UM p.217: H, "Stop on Path? Yes, Stop at Prog Pt? No" (SRM p.260: "can be started up
        // again with an R"): the motors end holding on the path, the program held.
        let cfg = config("motion");
        let check = cycle_check("H stops on the path: its motors end holding, and R can resume the program");
        let mut prev = moving_card(&cfg);
        prev.apply_with_decel(&cfg, &command("&1H"), 1);
        assert_eq!(prev.axes.motors()[0].stop, Some(Stop::Hold));
        let (report, next) = cycle(&cfg, &prev);
        assert_eq!((next.axes.motors()[0].state, program(&next, 1)), (MotorState::Holding, Program::Held));
        assert!(check(&cfg, &prev, report, &next), "the model's end of H holds");
        let mut closed = next.clone();
        closed.axes.motors_mut()[0].state = MotorState::Closed;
        assert!(!check(&cfg, &prev, report, &closed), "H ending closed loop off the path fires");
        let mut at_point = next.clone();
        at_point.axes.programs_mut()[0] = Program::AtPoint;
        assert!(!check(&cfg, &prev, report, &at_point), "H ending at a program point fires");
        // The card trips while the hold decelerates: the motor is killed, no hold: holds.
        let after = tripped_killing_motor_1(&prev);
        assert!(check(&cfg, &prev, report, &after), "a trip during the hold holds");
    }

    #[test]
    fn sentence_um_217_a_coordinate_system_command_leaves_the_other_systems_motors() {
        // UM p.217: Scope "C.S." for A, Q, /, H and \: &1A stops motor 1 (in &1), motor 2 (in
        // &2) jogs on untouched.
        let cfg = config("motion");
        let check = event_check("a coordinate-system command acts only on the motors of its coordinate system");
        let prev = moving_card(&cfg);
        let ev = command("&1A");
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_ne!(next.axes.motors()[0], prev.axes.motors()[0], "&1A changes motor 1");
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's &1A holds");
        let mut reached = next.clone();
        reached.axes.motors_mut()[1].state = MotorState::Decelerating;
        assert!(!check(&cfg, &prev, &ev, reply, &reached), "&1A stopping motor 2 fires");
    }

    #[test]
    fn sentence_srm_260_ctrl_o_holds_every_program_and_ctrl_q_quits_every_program_motor() {
        // SRM p.260: <CTRL-O> "is equivalent to issuing the H command to each coordinate
        // system"; <CTRL-Q> is Q for each (UM p.217): every program motor finishing its move.
        let cfg = config("motion");
        let check = event_check("<CTRL-O> holds every running program and <CTRL-Q> quits each");
        let prev = moving_card(&cfg);
        let hold = command("<CTRL-O>");
        let (next, reply) = step(&cfg, &prev, &hold);
        assert_eq!(program(&next, 1), Program::Held);
        assert!(check(&cfg, &prev, &hold, reply, &next), "the model's <CTRL-O> holds");
        let mut running = next.clone();
        running.axes.programs_mut()[0] = Program::Running;
        assert!(!check(&cfg, &prev, &hold, reply, &running), "<CTRL-O> leaving &1 running fires");
        let quit = command("<CTRL-Q>");
        let (next, reply) = step(&cfg, &prev, &quit);
        assert_eq!(next.axes.motors()[0].stop, Some(Stop::Quit));
        assert!(check(&cfg, &prev, &quit, reply, &next), "the model's <CTRL-Q> holds (motor 2 jogs on, no program)");
        let mut unstopped = next.clone();
        unstopped.axes.motors_mut()[0].stop = None;
        assert!(!check(&cfg, &prev, &quit, reply, &unstopped), "<CTRL-Q> leaving motor 1's program unstopped fires");
    }

    /// `encoder-loss` (one motor, the PLC of UM p.214-215) under `profile`, motor 1 enabled,
    /// a background cycle possible.
    fn encoder_card(profile: &str) -> (ModelConfig, Controller) {
        let spec = Spec::embedded().unwrap();
        let cfg = ModelConfig::from_spec(&spec, "encoder-loss", &spec.profiles.get(profile).unwrap()).unwrap();
        let mut c = card_after(&cfg, &["#1J/"]);
        c.background_credit = u32::from(c.load.background_units);
        assert!(c.background_possible());
        (cfg, c)
    }

    #[test]
    fn sentence_um_214_the_plc_kills_a_closed_loop_motor_whose_encoder_is_lost_and_latches_the_loss() {
        // UM p.214-215: the encoder-loss PLC, scanning once per background cycle, kills a
        // closed-loop motor whose encoder-loss input reports loss and latches the loss.
        let (cfg, mut prev) = encoder_card("um-215");
        let check = event_check(
            "a closed-loop motor whose encoder is lost has every motor killed at the next background cycle, its loss latched",
        );
        prev.axes.motors_mut()[0].encoder_lost = true;
        let ev = Event::Background;
        let (next, reply) = step(&cfg, &prev, &ev);
        assert!(next.axes.motors()[0].state == MotorState::Killed && next.axes.motors()[0].loss_status);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's scan holds");
        let mut running = next.clone();
        running.axes.motors_mut()[0].state = MotorState::Closed;
        assert!(!check(&cfg, &prev, &ev, reply, &running), "the motor left closed loop fires");
        let mut unlatched = next.clone();
        unlatched.axes.motors_mut()[0].loss_status = false;
        assert!(!check(&cfg, &prev, &ev, reply, &unlatched), "the loss not latched fires");
        // No scan without a background cycle: a servo cycle, or a background not yet due.
        let servo = Event::Servo { cycles: 1 };
        let (next, reply) = step(&cfg, &prev, &servo);
        assert_eq!(next.axes.motors()[0].state, MotorState::Closed);
        assert!(check(&cfg, &prev, &servo, reply, &next), "a servo cycle holds");
        let mut busy = prev.clone();
        busy.background_credit = 0;
        let (next, reply) = step(&cfg, &busy, &ev);
        assert_eq!(next.axes.motors()[0].state, MotorState::Closed);
        assert!(check(&cfg, &busy, &ev, reply, &next), "no background cycle possible holds");
        // A healthy motor is not killed, and that holds.
        prev.axes.motors_mut()[0].encoder_lost = false;
        let (next, reply) = step(&cfg, &prev, &ev);
        assert_eq!(next.axes.motors()[0].state, MotorState::Closed);
        assert!(check(&cfg, &prev, &ev, reply, &next), "a healthy motor's scan holds");
    }

    #[test]
    fn sentence_um_214_the_plc_s_cmd_k_kills_every_motor_and_latches_only_the_lost_one() {
        // UM p.214-215: "CMD^K ; Kill all motors": motor 1's lost encoder kills motor 2 too,
        // jogging in another coordinate system (encoder-loss-2: motor 1 in &1, motor 2 in &2).
        let spec = Spec::embedded().unwrap();
        let cfg = ModelConfig::from_spec(&spec, "encoder-loss-2", &spec.profiles.get("um-215").unwrap()).unwrap();
        let mut prev = card_after(&cfg, &["#1J/", "#2J/", "#2J+"]);
        prev.background_credit = u32::from(prev.load.background_units);
        prev.axes.motors_mut()[0].encoder_lost = true;
        assert_eq!(prev.axes.motors()[1].state, MotorState::Jogging);
        let check = event_check(
            "a closed-loop motor whose encoder is lost has every motor killed at the next background cycle, its loss latched",
        );
        let ev = Event::Background;
        let (next, reply) = step(&cfg, &prev, &ev);
        assert!(next.axes.motors().iter().all(|m| m.state == MotorState::Killed), "every motor killed");
        assert_eq!((next.axes.motors()[0].loss_status, next.axes.motors()[1].loss_status), (true, false));
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's scan holds");
        let mut jogging = next.clone();
        jogging.axes.motors_mut()[1] = prev.axes.motors()[1];
        assert!(!check(&cfg, &prev, &ev, reply, &jogging), "motor 2 left jogging fires (the rule before issue 35)");
    }

    #[test]
    fn sentence_um_215_the_loss_is_latched_only_by_the_plc_s_scan() {
        // UM p.215: the PLC "scans ... once per background cycle": outside one, no status goes
        // from clear to latched; a status already latched may stay.
        let (cfg, prev) = encoder_card("um-215");
        let check = event_check("the encoder-loss status is latched only by the PLC's scan in a background cycle");
        let servo = Event::Servo { cycles: 1 };
        let (next, reply) = step(&cfg, &prev, &servo);
        assert!(check(&cfg, &prev, &servo, reply, &next), "a servo cycle holds");
        let mut latched = next.clone();
        latched.axes.motors_mut()[0].loss_status = true;
        assert!(!check(&cfg, &prev, &servo, reply, &latched), "a servo cycle latching the loss fires");
        assert!(check(&cfg, &prev, &Event::Background, reply, &latched), "a background cycle latching it holds");
        let mut was = prev.clone();
        was.axes.motors_mut()[0].loss_status = true;
        assert!(check(&cfg, &was, &servo, reply, &latched), "a latched loss staying latched holds");
    }

    #[test]
    fn sentence_um_215_read_as_intended_the_plc_clears_a_latched_loss_of_a_healthy_closed_loop_motor() {
        // UM p.215, "Logic to clear fault status", read as intended (facts s.6): a closed-loop
        // motor with its encoder OK has its latched loss cleared at the next scan. A killed
        // motor keeps it; under the literal reading nothing clears it.
        let (cfg, mut prev) = encoder_card("um-215");
        let check = event_check("under the intended reading the PLC clears a latched loss once the motor is closed-loop with its encoder OK");
        prev.axes.motors_mut()[0].loss_status = true;
        let ev = Event::Background;
        let (next, reply) = step(&cfg, &prev, &ev);
        assert!(!next.axes.motors()[0].loss_status);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's clear holds");
        assert!(!check(&cfg, &prev, &ev, reply, &prev), "the loss left latched fires");
        let servo = Event::Servo { cycles: 1 };
        assert!(check(&cfg, &prev, &servo, reply, &prev), "no scan outside a background cycle holds");
        let mut busy = prev.clone();
        busy.background_credit = 0;
        assert!(check(&cfg, &busy, &ev, reply, &busy), "no background cycle possible holds");
        let mut lost = prev.clone();
        lost.axes.motors_mut()[0].encoder_lost = true;
        let mut kept = lost.clone();
        kept.axes.motors_mut()[0].state = MotorState::Killed;
        assert!(check(&cfg, &lost, &ev, reply, &kept), "a lost encoder keeps the loss: holds");
        let mut killed = prev.clone();
        killed.axes.motors_mut()[0].state = MotorState::Killed;
        let (next, reply) = step(&cfg, &killed, &ev);
        assert!(next.axes.motors()[0].loss_status);
        assert!(check(&cfg, &killed, &ev, reply, &next), "a killed motor keeps the loss: holds");
        let (literal, mut lprev) = encoder_card("um-215-literal-plc");
        lprev.axes.motors_mut()[0].loss_status = true;
        assert!(check(&literal, &lprev, &ev, reply, &lprev), "under the literal reading the loss stays: holds");
    }

    #[test]
    fn sentence_um_215_read_literally_a_latched_loss_stays_until_a_reset() {
        // UM p.215 as printed: "IF (Mtr1OpenLoop=0 AND Enc1LossIn=OK AND Mtr1EncLossStatus=0)
        // Mtr1EncLossStatus=0" never clears a latched status; only a reset does.
        let (cfg, mut prev) = encoder_card("um-215-literal-plc");
        let check = event_check("under the literal reading a latched encoder loss stays latched until a reset");
        prev.axes.motors_mut()[0].loss_status = true;
        let ev = Event::Background;
        let (next, reply) = step(&cfg, &prev, &ev);
        assert!(next.axes.motors()[0].loss_status);
        assert!(check(&cfg, &prev, &ev, reply, &next), "the model's scan holds");
        let mut cleared = next.clone();
        cleared.axes.motors_mut()[0].loss_status = false;
        assert!(!check(&cfg, &prev, &ev, reply, &cleared), "a scan clearing the loss fires");
        let reset = command("$$$");
        let (next, reply) = step(&cfg, &prev, &reset);
        assert!(!next.axes.motors()[0].loss_status);
        assert!(check(&cfg, &prev, &reset, reply, &next), "a reset clearing it holds");
        let (intent, iprev) = encoder_card("um-215");
        let mut iprev = iprev;
        iprev.axes.motors_mut()[0].loss_status = true;
        assert!(check(&intent, &iprev, &ev, reply, &cleared), "under the intended reading the clear holds");
    }

    #[test]
    fn bit_reads_one_bit_of_a_status_word_and_no_other() {
        // SRM p.289: the `???` words are read bit by bit.
        assert!(bit(1 << 22, 22));
        assert!(!bit(1 << 22, 9));
        assert!(!bit(0, 0));
        assert!(!bit(!(1 << 5), 5), "a word with every other bit set");
    }

    #[test]
    fn a_host_s_dollar_dollar_dollar_and_reinitialization_are_resets_and_ordinary_events_are_not() {
        // SRM p.289 / UM p.243: $$$ and $$$*** reset the card, as INIT/ and a power cycle do.
        assert!(is_reset(&Event::Command(HostCommand::Reset)));
        assert!(is_reset(&Event::Command(HostCommand::Reinitialize)));
        for e in [Event::Servo { cycles: 1 }, Event::Background, Event::Command(HostCommand::GlobalStatus)] {
            assert!(!is_reset(&e), "{e:?} is no reset");
        }
    }

    #[test]
    fn the_members_of_a_coordinate_system_are_its_motors_only() {
        // UM p.217: a coordinate-system command acts on the motors of that system. `motion`
        // has motor 1 in C.S. 1 and motor 2 in C.S. 2.
        let cfg = motion_config();
        assert_eq!(members(&cfg, 1).collect::<Vec<_>>(), [0]);
        assert_eq!(members(&cfg, 2).collect::<Vec<_>>(), [1]);
        assert_eq!(members(&cfg, 3).count(), 0, "no motor in a system the configuration leaves empty");
    }

    #[test]
    fn only_a_status_reply_can_be_twelve_hex_characters_of_its_words() {
        // SRM p.289: `???` answers 12 hex characters, first word first. Any other reply, and a
        // bootstrap card's `BOOTSTRAP PROM`, is not such a text; asked twice, the same answer
        // (the second from the per-thread memory).
        for _ in 0..2 {
            assert!(status_text_is_the_words(Reply::Status { x: 0x00_1000, y: 0x80_0400 }));
            assert!(!status_text_is_the_words(Reply::Ack));
            assert!(!status_text_is_the_words(Reply::Bootstrap));
        }
    }
}
