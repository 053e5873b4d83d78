//! The core's motion on its own, rule by rule: each test drives the core with its own commands
//! and checks one sentence of the manuals. (Lockstep checks every rule against the model too;
//! these tests keep the core's behaviour readable, and fail on the core alone.)

mod common;

use pmacwd_core::motion::{CsCommand, GlobalCommand, MotorCommand, MotorState, Program, Stop};
use pmacwd_core::{Command, Config, Core, Event, FewIVariables, MotionCommand, MotionConfig, Reply};

/// Two motors, #1 in &1 and #2 in &2, stops taking 3 servo cycles.
fn config() -> Config {
    Config {
        motion: MotionConfig { motors: 2, coordinate_systems: [1, 2, 1, 1, 1, 1, 1, 1], decel_cycles: 3 },
        ..common::realistic_config()
    }
}

struct Card {
    cfg: Config,
    core: Core,
    store: FewIVariables<4>,
}

impl Card {
    fn new(cfg: Config) -> Card {
        Card { core: Core::power_on(&cfg), cfg, store: FewIVariables::default() }
    }

    fn send(&mut self, m: MotionCommand) -> Reply {
        self.core.apply(&self.cfg, Event::Command(Command::Motion(m)), &mut self.store)
    }

    fn motor(&mut self, n: u8, c: MotorCommand) -> Reply {
        self.send(MotionCommand::Motor(n, c))
    }

    fn cs(&mut self, n: u8, c: CsCommand) -> Reply {
        self.send(MotionCommand::CoordinateSystem(n, c))
    }

    fn servo(&mut self, n: u32) {
        self.core.apply(&self.cfg, Event::Servo(n), &mut self.store);
    }

    fn state(&self, n: u8) -> MotorState {
        self.core.motor(&self.cfg, n).expect("configured motor").state
    }

    /// #1 closed-loop and &1 running its program.
    fn running(cfg: Config) -> Card {
        let mut c = Card::new(cfg);
        c.motor(1, MotorCommand::JogStop);
        c.cs(1, CsCommand::Begin);
        c.cs(1, CsCommand::Run);
        assert_eq!(c.state(1), MotorState::Program);
        c
    }
}

/// MODEL (Ixx80 = 0): motors power up killed, amplifier off, output at zero; J/ closes the loop.
#[test]
fn motors_power_up_killed_and_j_slash_closes_the_loop() {
    let mut c = Card::new(config());
    let m = c.core.motor(&c.cfg, 1).unwrap();
    assert_eq!((m.state, m.amplifier_enabled, m.output_zero), (MotorState::Killed, false, true));
    assert_eq!(c.motor(1, MotorCommand::JogStop), Reply::Ack);
    let m = c.core.motor(&c.cfg, 1).unwrap();
    assert_eq!((m.state, m.amplifier_enabled, m.output_zero), (MotorState::Closed, true, false));
    assert_eq!(c.core.motor(&c.cfg, 3), None, "the configuration has two motors");
}

/// MODEL, as the reference model: a motor the configuration does not have is not set up
/// (Ixx00 = 0, the motor not activated) and a command to it does nothing: #3 of a
/// two-motor card, and #0, leave the motion exactly as it was, whatever the command.
#[test]
fn a_command_to_a_motor_the_configuration_does_not_have_does_nothing() {
    let mut c = Card::new(config());
    for n in [0u8, 3] {
        for cmd in [MotorCommand::JogStop, MotorCommand::Jog, MotorCommand::JogStop, MotorCommand::Kill] {
            let before = c.core.motion();
            assert_eq!(c.motor(n, cmd), Reply::Ack, "#{n} {cmd:?}");
            assert_eq!(c.core.motion(), before, "#{n} {cmd:?}");
        }
    }
}

/// UM p.217 row 1: J/ begins immediately and decelerates (Ixx19-21) to closed loop at rest,
/// here in the configured 3 servo cycles.
#[test]
fn j_slash_decelerates_a_jog_for_the_configured_cycles() {
    let mut c = Card::new(config());
    c.motor(1, MotorCommand::JogStop);
    c.motor(1, MotorCommand::Jog);
    assert_eq!(c.state(1), MotorState::Jogging);
    c.motor(1, MotorCommand::JogStop);
    assert_eq!(c.core.motor(&c.cfg, 1).unwrap().stop, Some((Stop::Jog, 3)));
    c.servo(2);
    assert_eq!(c.state(1), MotorState::Decelerating);
    c.servo(1);
    assert_eq!(c.state(1), MotorState::Closed);
}

/// UM p.319: K "is not permitted when the motor is in a coordinate system that is executing a
/// motion program" (ERR001); after A has stopped the program, K kills in the same event.
#[test]
fn k_is_refused_while_the_program_runs_and_kills_once_a_stops_it() {
    let mut c = Card::running(config());
    assert_eq!(c.motor(1, MotorCommand::Kill), Reply::Error(1));
    assert_eq!(c.state(1), MotorState::Program);
    c.cs(1, CsCommand::Abort);
    assert_eq!(c.core.motor(&c.cfg, 1).unwrap().program, Program::Lost);
    assert_eq!(c.motor(1, MotorCommand::Kill), Reply::Ack);
    let m = c.core.motor(&c.cfg, 1).unwrap();
    assert_eq!((m.state, m.amplifier_enabled, m.output_zero), (MotorState::Killed, false, true));
}

/// UM p.217: Q does not begin immediately, it "Finishes calculated moves" and stops at a
/// program point: the motor stays in the program until the stop ends, then the program
/// stands at a point that R continues from.
#[test]
fn q_finishes_the_calculated_moves_and_stops_at_a_program_point() {
    let mut c = Card::running(config());
    c.cs(1, CsCommand::Quit);
    assert_eq!(c.state(1), MotorState::Program);
    c.servo(3);
    let m = c.core.motor(&c.cfg, 1).unwrap();
    assert_eq!((m.state, m.program), (MotorState::Closed, Program::AtPoint));
    c.cs(1, CsCommand::Run);
    assert_eq!(c.state(1), MotorState::Program);
}

/// UM p.217 rows 4 and 6: Q "Finishes calculated moves", / ends at the "End of currently
/// executing move": the stop a motor reports (as `#n?` shows it) is the row of the command
/// given, though both end alike, at a program point.
#[test]
fn q_and_slash_each_report_their_own_row_of_the_stop_table() {
    for (command, stop) in [(CsCommand::Quit, Stop::Quit), (CsCommand::EndOfMove, Stop::EndOfMove)] {
        let mut c = Card::running(config());
        c.cs(1, command);
        assert_eq!(c.core.motor(&c.cfg, 1).unwrap().stop, Some((stop, 3)), "{command:?}");
    }
}

/// UM p.217: H stops on the path, not at a program point ("Similar to %0"); SRM p.260: R
/// starts a held C.S. again. A C.S. command leaves the other C.S. alone.
#[test]
fn h_holds_its_own_coordinate_system_on_the_path_and_r_resumes_it() {
    let mut c = Card::running(config());
    c.motor(2, MotorCommand::JogStop);
    c.motor(2, MotorCommand::Jog);
    c.cs(1, CsCommand::Hold);
    c.servo(3);
    let m = c.core.motor(&c.cfg, 1).unwrap();
    assert_eq!((m.state, m.program), (MotorState::Holding, Program::Held));
    assert_eq!(c.state(2), MotorState::Jogging, "&1H does not reach #2 in &2");
    c.cs(1, CsCommand::Feedrate(100));
    assert_eq!(c.state(1), MotorState::Program, "a non-zero %n resumes a hold, as R does");
}

/// UM p.319: <CTRL-K> disables every motor at once, even in a running program, and the
/// lookahead is discarded.
#[test]
fn ctrl_k_kills_every_motor_at_once_even_in_a_running_program() {
    let mut c = Card::running(config());
    c.motor(2, MotorCommand::JogStop);
    c.motor(2, MotorCommand::Jog);
    assert_eq!(c.send(MotionCommand::Global(GlobalCommand::KillAll)), Reply::Ack);
    assert_eq!((c.state(1), c.state(2)), (MotorState::Killed, MotorState::Killed));
    assert_eq!(c.core.motor(&c.cfg, 1).unwrap().program, Program::Lost);
}

/// UM p.215: a trip forces every output off: every amplifier is disabled, every motor reads
/// killed, in the servo cycle that trips (here an undervoltage).
#[test]
fn a_trip_kills_every_motor() {
    let mut c = Card::running(config());
    c.core.apply(&c.cfg, Event::Supply(4500), &mut c.store);
    assert!(c.core.tripped());
    for n in 1..=2 {
        let m = c.core.motor(&c.cfg, n).unwrap();
        assert_eq!((m.state, m.amplifier_enabled, m.output_zero), (MotorState::Killed, false, true), "#{n}");
    }
}

/// UM p.215: the trip forces the outputs ("discrete outputs off, and proportional outputs ...
/// to zero-level"), not the card's memory: a running program's coordinate system still reads
/// Running, and held one Held, while the card is tripped (MODEL, as the reference model's
/// `force_off`, which kills the motors and leaves the programs); a reset clears them.
#[test]
fn a_trip_leaves_the_programs_where_they_stood() {
    let mut c = Card::running(config());
    c.motor(2, MotorCommand::JogStop);
    c.cs(2, CsCommand::Begin);
    c.cs(2, CsCommand::Run);
    c.cs(2, CsCommand::Hold);
    c.core.apply(&c.cfg, Event::Supply(4500), &mut c.store);
    assert!(c.core.tripped());
    let (one, two) = (c.core.motor(&c.cfg, 1).unwrap(), c.core.motor(&c.cfg, 2).unwrap());
    assert_eq!((one.state, one.program), (MotorState::Killed, Program::Running));
    assert_eq!((two.state, two.program), (MotorState::Killed, Program::Held));
    assert!(c.core.motion().consistent());
}

/// UM p.214-215: the encoder-loss PLC, one scan per background cycle, kills a closed-loop
/// motor whose encoder is lost and latches the loss; with the encoder back, the intended
/// reading clears the latch and the literal one (which tests for a status already 0) never does.
#[test]
fn the_encoder_loss_plc_kills_and_latches_and_only_the_intended_reading_clears() {
    for intended in [true, false] {
        let mut cfg = config();
        cfg.profile.encoder_loss_clear_intended = intended;
        let mut c = Card::new(cfg);
        c.motor(1, MotorCommand::JogStop);
        c.core.apply(&c.cfg, Event::EncoderInput { motor: 1, lost: true }, &mut c.store);
        assert_eq!(c.state(1), MotorState::Closed, "the PLC acts in the background, not at the input");
        let background = |c: &mut Card| {
            while !c.core.background_possible() {
                c.servo(1);
            }
            c.core.background_cycle(&c.cfg);
        };
        background(&mut c);
        let m = c.core.motor(&c.cfg, 1).unwrap();
        assert_eq!((m.state, m.encoder_loss_status), (MotorState::Killed, true));
        c.core.apply(&c.cfg, Event::EncoderInput { motor: 1, lost: false }, &mut c.store);
        c.motor(1, MotorCommand::JogStop);
        background(&mut c);
        assert_eq!(c.core.motor(&c.cfg, 1).unwrap().encoder_loss_status, !intended, "intended reading: {intended}");
    }
}

/// UM p.214-215: the PLC answers a lost encoder with CMD^K, "Kill all motors": motor 1's loss
/// kills motor 2 too, in another coordinate system, and the program running there loses its
/// lookahead (UM p.319); only motor 1's loss is latched. (Before issue 35 the core killed
/// motor 1 alone and aborted only its own C.S.: motor 2 kept moving.)
#[test]
fn the_encoder_loss_plc_kills_every_motor_in_every_coordinate_system() {
    let cfg = Config {
        motion: MotionConfig { motors: 3, coordinate_systems: [1, 2, 2, 1, 1, 1, 1, 1], decel_cycles: 3 },
        ..config()
    };
    let mut c = Card::new(cfg);
    for m in 1..=3 {
        c.motor(m, MotorCommand::JogStop);
    }
    c.cs(2, CsCommand::Begin);
    c.cs(2, CsCommand::Run);
    c.core.apply(&c.cfg, Event::EncoderInput { motor: 1, lost: true }, &mut c.store);
    while !c.core.background_possible() {
        c.servo(1);
    }
    assert_eq!(c.core.motor(&c.cfg, 2).unwrap().state, MotorState::Program);
    c.core.background_cycle(&c.cfg);
    for m in 1..=3 {
        let s = c.core.motor(&c.cfg, m).unwrap();
        assert_eq!((s.state, s.amplifier_enabled), (MotorState::Killed, false), "motor {m}");
        assert_eq!(s.encoder_loss_status, m == 1, "motor {m}: only the lost encoder's status is latched");
    }
    assert_eq!(c.core.motor(&c.cfg, 2).unwrap().program, Program::Lost);
    assert!(c.core.motion().consistent());
}

/// A reset brings every motor and program back to power-up; the encoder input, hardware,
/// keeps its level (UM p.215: a reset restores "normal functioning").
#[test]
fn a_reset_restarts_the_motors_and_keeps_the_encoder_inputs() {
    let mut c = Card::running(config());
    c.core.apply(&c.cfg, Event::EncoderInput { motor: 2, lost: true }, &mut c.store);
    c.core.apply(&c.cfg, Event::Command(Command::Reset), &mut c.store);
    let (one, two) = (c.core.motor(&c.cfg, 1).unwrap(), c.core.motor(&c.cfg, 2).unwrap());
    assert_eq!((one.state, one.program), (MotorState::Killed, Program::None));
    assert!(two.encoder_lost);
    assert!(c.core.motion().consistent());
}

/// The quiet stretches (`stretch.rs`) end before the first stop under way does, and read that
/// from `cycles_before_a_stop_ends`: none under way, no limit; a stop of c cycles left ends on
/// the c-th cycle, so c - 1 may pass first; with several, the nearest; and `stops_under_way`
/// says whether there is any. A limit too low only costs speed, so the deferral's own tests
/// cannot see it; this states the contract directly (cargo-mutants: the function returning 0
/// or 1, `stops_under_way` returning true).
#[test]
fn the_cycles_before_a_stop_ends_are_those_of_the_nearest_stop_less_one() {
    let (cfg, mut core) = common::moving(40, 0);
    assert!(!core.motion().stops_under_way(), "eight motors jogging, none stopping");
    assert_eq!(core.motion().cycles_before_a_stop_ends(), u32::MAX);
    let mut store = FewIVariables::<4>::default();
    let stop = |core: &mut Core, store: &mut FewIVariables<4>, n: u8| {
        core.apply(&cfg, Event::Command(Command::Motion(MotionCommand::Motor(n, MotorCommand::JogStop))), store)
    };
    stop(&mut core, &mut store, 1);
    assert!(core.motion().stops_under_way());
    assert_eq!(core.motion().cycles_before_a_stop_ends(), 39, "a J/ of 40 cycles");
    core.advance(&cfg, 10);
    stop(&mut core, &mut store, 2);
    assert_eq!(core.motion().cycles_before_a_stop_ends(), 29, "#1 has 30 left, #2 40: the nearest");
    core.advance(&cfg, 30);
    assert_eq!(core.motion().cycles_before_a_stop_ends(), 9, "#1 ended, #2 has 10 left");
    core.advance(&cfg, 10);
    assert!(!core.motion().stops_under_way(), "both stops ended");
    assert_eq!(core.motion().cycles_before_a_stop_ends(), u32::MAX);
}

/// MODEL, as the reference model (docs/grammar.md, `E`): `&nE` closes the loop of each killed
/// motor of C.S. n as J/ closes a killed motor's (UM p.319), and clears its amplifier-fault
/// status bit (UM p.213); a motor of another C.S. stays killed, a jogging one jogs on.
#[test]
fn e_closes_the_killed_loops_of_its_coordinate_system_only() {
    let mut c = Card::new(config());
    assert_eq!(c.cs(1, CsCommand::Enable), Reply::Ack);
    assert_eq!((c.state(1), c.state(2)), (MotorState::Closed, MotorState::Killed));
    let m1 = c.core.motor(&c.cfg, 1).unwrap();
    assert!(m1.amplifier_enabled && !m1.output_zero);
    c.motor(1, MotorCommand::Jog);
    c.cs(1, CsCommand::Enable);
    c.cs(2, CsCommand::Enable);
    assert_eq!((c.state(1), c.state(2)), (MotorState::Jogging, MotorState::Closed));
    assert!(c.core.motion().consistent());
    // UM p.213: the fault kills #2 and sets its bit at the background's check; E clears it.
    c.core.apply(&c.cfg, Event::AmplifierFault { motor: 2, fault: true }, &mut c.store);
    let mut checked = false;
    for _ in 0..1000 {
        c.servo(1);
        if c.core.background_possible() {
            c.core.apply(&c.cfg, Event::Background, &mut c.store);
            checked = true;
            break;
        }
    }
    assert!(checked, "a background cycle completes");
    let m2 = c.core.motor(&c.cfg, 2).unwrap();
    assert_eq!((m2.state, m2.amplifier_fault_status), (MotorState::Killed, true));
    c.core.apply(&c.cfg, Event::AmplifierFault { motor: 2, fault: false }, &mut c.store);
    c.cs(2, CsCommand::Enable);
    let m2 = c.core.motor(&c.cfg, 2).unwrap();
    assert_eq!((m2.state, m2.amplifier_fault_status), (MotorState::Closed, false));
}
