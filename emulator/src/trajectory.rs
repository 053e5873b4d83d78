//! Motor trajectories: where each motor of the emulated card is commanded to be, in counts,
//! and how fast it goes, advanced by the servo clock. A layer over the compact core: the core
//! keeps each motor's abstract state (killed, closed, jogging, decelerating ...: the
//! model-checked watchdog and stop rules), and the card (`card.rs`) keeps every trajectory
//! within it: a motor moves only while the core says it jogs, a stop the core carries out ends
//! the trajectory in exactly the servo cycles the core gives it, and a kill or a trip stops it
//! at once.
//!
//! Units are the card's: positions in counts, velocities in counts/ms, accelerations in
//! counts/ms², time in ms (the servo period is I10, SRM p.42-43). Each trajectory is a chain
//! of constant-acceleration pieces and is advanced in closed form, so advancing it by a
//! million servo cycles costs what advancing it by one does.
//!
//! MODEL: the commanded position is also the actual one (no servo loop, no load): the
//! following error is 0 unless the control port injects one.

/// Where a trajectory is headed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Goal {
    /// At rest, holding its position.
    Hold,
    /// To velocity `v` (counts/ms) and on at it: `J+`, `J-`, a homing search (SRM p.101, Ixx22
    /// and Ixx23).
    Velocity { v: f64 },
    /// To `target` (counts) at most `speed` (counts/ms): `J=`, `J^`, `J:`, the post-trigger
    /// move of a homing search.
    Position { target: f64, speed: f64 },
    /// To rest at `rate` (counts/ms²): a stop the core is carrying out.
    Stop { rate: f64 },
}

/// Where a homing search stands (SRM p.101 Ixx23; PMAC-SRM p.82 Ix26).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Homing {
    None,
    /// Moving at the home speed until the home flag triggers.
    Searching,
    /// The flag triggered: moving to the trigger position plus the home offset.
    PostTrigger,
}

/// One motor's trajectory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    /// Commanded position, counts from where the motor stood at power-up.
    pub pos: f64,
    /// Commanded velocity, counts/ms.
    pub vel: f64,
    pub goal: Goal,
    /// The acceleration of the move under way, counts/ms² (always > 0).
    pub accel: f64,
    pub homing: Homing,
    /// The trigger position plus the home offset, while [`Homing::PostTrigger`].
    pub home_target: f64,
    /// The position that reads 0 (power-up: where the motor stood; after a homing search or
    /// `HMZ`, the home position).
    pub origin: f64,
    /// A homing search completed since power-up (SRM p.284, second word bit 10).
    pub home_complete: bool,
    /// A move to a position (a definite end point) is under way: the move timer (SRM p.283,
    /// first word bit 17).
    pub move_timer: bool,
    /// Where the last jog started, for `J=` with no value (jog to the pre-jog position).
    pub pre_jog: f64,
    /// A following error the control port injected, counts (0: none).
    pub following_error: f64,
    /// The last move ended on a position limit (SRM p.284, second word bit 11).
    pub limit_stop: bool,
}

/// The limits a move must stop at: the software limits (counts from power-up; SRM p.95-97,
/// Ixx13 and Ixx14, `None` when 0: none) and the rate of a limit stop (Ixx15, counts/ms²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub plus: Option<f64>,
    pub minus: Option<f64>,
    pub decel: f64,
}

impl Limits {
    pub const NONE: Limits = Limits { plus: None, minus: None, decel: 1.0 };
}

/// Below this, a velocity is zero (counts/ms): a millionth of a count per second.
const VELOCITY_EPS: f64 = 1e-9;

/// Pieces a trajectory may pass through in one advance: accelerate, cruise, decelerate, a
/// trigger, a reversal, the post-trigger move ... a dozen at most; the bound keeps an advance
/// finite whatever rounding does.
const PIECES_PER_ADVANCE_MAX: usize = 16;

impl Default for Axis {
    fn default() -> Self {
        Axis {
            pos: 0.0,
            vel: 0.0,
            goal: Goal::Hold,
            accel: 1.0,
            homing: Homing::None,
            home_target: 0.0,
            origin: 0.0,
            home_complete: false,
            move_timer: false,
            pre_jog: 0.0,
            following_error: 0.0,
            limit_stop: false,
        }
    }
}

impl Axis {
    /// The position a host reads (`P`): counts from the origin.
    pub fn reported_position(&self) -> f64 {
        self.pos - self.origin
    }

    /// Whether the commanded velocity is zero and nothing is about to move the motor.
    pub fn at_rest(&self) -> bool {
        self.goal == Goal::Hold && self.vel.abs() <= VELOCITY_EPS
    }

    /// Stops at once where it is (a kill, a trip, a deactivated motor): MODEL, no coasting.
    pub fn halt(&mut self) {
        self.vel = 0.0;
        self.goal = Goal::Hold;
        self.homing = Homing::None;
        self.move_timer = false;
    }

    /// Starts a jog: at `speed` towards `target`, or on at `speed` in the direction of
    /// `direction` when there is no target; `accel` the rate (counts/ms²).
    pub fn jog(&mut self, target: Option<f64>, direction: f64, speed: f64, accel: f64) {
        if self.at_rest() {
            self.pre_jog = self.pos;
        }
        self.accel = accel;
        self.homing = Homing::None;
        self.limit_stop = false;
        match target {
            Some(t) => {
                self.goal = Goal::Position { target: t, speed };
                self.move_timer = true;
            }
            None => {
                self.goal = Goal::Velocity { v: direction.signum() * speed };
                self.move_timer = false;
            }
        }
    }

    /// Starts a motion program's move to `target` (counts from power-up) at most `speed`
    /// (counts/ms), accelerating and decelerating at `accel`: a linear move of its coordinate
    /// system (`card/program.rs`). The move timer runs while it moves (SRM p.283).
    pub fn program_move(&mut self, target: f64, speed: f64, accel: f64) {
        self.accel = accel;
        self.homing = Homing::None;
        self.limit_stop = false;
        self.goal = Goal::Position { target, speed };
        self.move_timer = true;
    }

    /// The time (ms) until a move to a position arrives, limits aside (`None`: no move to a
    /// position is under way, or it does not arrive within a dozen pieces).
    pub fn time_to_arrive(&self) -> Option<f64> {
        let Goal::Position { target, speed } = self.goal else { return None };
        // Long enough for any move a piece at a time, short enough to keep the sum exact.
        const LONG: f64 = 1.0e9;
        let mut copy = *self;
        let mut used = 0.0;
        for _ in 0..PIECES_PER_ADVANCE_MAX {
            let left = copy.towards(target, speed, LONG);
            used += LONG - left;
            if copy.goal == Goal::Hold {
                return Some(used);
            }
        }
        None
    }

    /// A program's move from rest that must end within `ms` (the servo cycles the core gives
    /// it): it goes to its target in exactly that time, accelerating for half of it.
    pub fn fit_move(&mut self, ms: f64) {
        if let Goal::Position { target, .. } = self.goal {
            let d = (target - self.pos).abs();
            if ms > 0.0 && d > 0.0 && self.vel.abs() <= VELOCITY_EPS {
                self.accel = 4.0 * d / (ms * ms);
                self.goal = Goal::Position { target, speed: 2.0 * d / ms };
            }
        }
    }

    /// Ends a program's move exactly at `target` (the move's time is up: what rounding left
    /// of it is taken at once).
    pub fn finish_move(&mut self, target: f64) {
        if let Goal::Position { target: t, .. } = self.goal {
            if t == target {
                self.arrive(target);
            }
        }
    }

    /// Starts a homing search at `velocity` (its sign the direction, SRM p.101 Ixx23).
    pub fn home(&mut self, velocity: f64, accel: f64) {
        self.accel = accel;
        self.homing = Homing::Searching;
        self.goal = Goal::Velocity { v: velocity };
        self.move_timer = true;
        self.home_complete = false;
        self.limit_stop = false;
    }

    /// Decelerates to rest at `rate` because a limit was reached (SRM p.96: an abort at Ixx15).
    pub fn limit(&mut self, rate: f64) {
        self.homing = Homing::None;
        self.move_timer = false;
        self.limit_stop = true;
        if self.vel.abs() <= VELOCITY_EPS {
            self.halt();
        } else {
            self.goal = Goal::Stop { rate };
        }
    }

    /// `HMZ`: the present position is the home position (zero), without moving.
    pub fn home_here(&mut self) {
        self.origin = self.pos;
        self.home_complete = true;
    }

    /// Brings the motor to rest within `ms`, as a stop the core carries out for that long; at
    /// once when it is already still.
    pub fn stop_within(&mut self, ms: f64) {
        self.homing = Homing::None;
        self.move_timer = false;
        if self.vel.abs() <= VELOCITY_EPS || ms <= 0.0 {
            self.halt();
            return;
        }
        self.goal = Goal::Stop { rate: self.vel.abs() / ms };
    }

    /// The time (ms) a stop from the present velocity takes at `rate`.
    pub fn stop_time(&self, rate: f64) -> f64 {
        if rate > 0.0 {
            self.vel.abs() / rate
        } else {
            0.0
        }
    }

    /// Moves along the trajectory for `t` ms; `home_flag` is where this motor's home flag
    /// triggers (counts from power-up), and `home_offset` the offset of the home position from
    /// the trigger (counts).
    pub fn advance(&mut self, t: f64, home_flag: Option<f64>, home_offset: f64, limits: &Limits) {
        let mut t = if t.is_finite() { t.max(0.0) } else { 0.0 };
        for _ in 0..PIECES_PER_ADVANCE_MAX {
            if t <= 0.0 {
                break;
            }
            let (p0, v0, before) = (self.pos, self.vel, t);
            let checked = !matches!(self.goal, Goal::Stop { .. } | Goal::Hold) && self.homing != Homing::Searching;
            match self.goal {
                Goal::Hold => {
                    self.vel = 0.0;
                    break;
                }
                Goal::Velocity { v } => {
                    let dv = v - self.vel;
                    let (piece, a) = if dv.abs() <= VELOCITY_EPS {
                        (t, 0.0)
                    } else {
                        ((dv.abs() / self.accel).min(t), self.accel * dv.signum())
                    };
                    if self.homing == Homing::Searching {
                        if let Some(flag) = home_flag {
                            if let Some(at) = crossing(self.pos, self.vel, a, flag, piece) {
                                self.step(at, a);
                                t -= at;
                                self.trigger(flag + home_offset);
                                continue;
                            }
                        }
                    }
                    self.step(piece, a);
                    t -= piece;
                    if (v - self.vel).abs() <= self.accel * 1e-9 + VELOCITY_EPS {
                        self.vel = v;
                        if v == 0.0 {
                            self.goal = Goal::Hold;
                        }
                    }
                }
                Goal::Stop { rate } => {
                    let left = self.vel.abs() / rate;
                    if left <= t {
                        self.step(left, -self.vel.signum() * rate);
                        self.halt();
                        break;
                    }
                    self.step(t, -self.vel.signum() * rate);
                    t = 0.0;
                }
                Goal::Position { target, speed } => t = self.towards(target, speed, t),
            }
            // SRM p.96-97: past a software limit the motor decelerates at Ixx15; during a
            // homing search the limits are off until the trigger.
            let used = before - t;
            if checked && used > 0.0 {
                let a = (self.vel - v0) / used;
                let plus = limits.plus.filter(|l| p0 < *l).and_then(|l| crossing(p0, v0, a, l, used));
                let minus = limits.minus.filter(|l| p0 > *l).and_then(|l| crossing(p0, v0, a, l, used));
                if let Some(at) = [plus, minus].into_iter().flatten().reduce(f64::min) {
                    (self.pos, self.vel) = (p0, v0);
                    self.step(at, a);
                    t = before - at;
                    self.limit(limits.decel);
                }
            }
        }
    }

    /// One piece of a move to `target` at most `speed`; returns the time left.
    fn towards(&mut self, target: f64, speed: f64, t: f64) -> f64 {
        let d = target - self.pos;
        let (dir, dist, v) = (d.signum(), d.abs(), self.vel.abs());
        let tolerance = 1e-9 * (1.0 + target.abs());
        if dist <= tolerance && v <= VELOCITY_EPS {
            self.arrive(target);
            return t;
        }
        // Moving away from the target: come to rest first.
        if self.vel * d < 0.0 {
            let piece = (v / self.accel).min(t);
            self.step(piece, -self.vel.signum() * self.accel);
            if piece < t {
                self.vel = 0.0;
            }
            return t - piece;
        }
        let stopping = v * v / (2.0 * self.accel);
        if stopping >= dist - tolerance {
            // The last deceleration, at the rate that lands exactly on the target.
            if v <= VELOCITY_EPS {
                self.arrive(target);
                return t;
            }
            let left = 2.0 * dist / v;
            if left <= t {
                self.arrive(target);
                return t - left;
            }
            self.step(t, -dir * v * v / (2.0 * dist));
            return 0.0;
        }
        if v > speed + VELOCITY_EPS {
            // Faster than the new speed (a jog's speed changed on the fly): slow down to it.
            let piece = ((v - speed) / self.accel).min(t);
            self.step(piece, -dir * self.accel);
            return t - piece;
        }
        let peak = (self.accel * dist + v * v / 2.0).sqrt().min(speed);
        if v < peak - VELOCITY_EPS {
            let piece = ((peak - v) / self.accel).min(t);
            self.step(piece, dir * self.accel);
            if piece < t {
                self.vel = dir * peak;
            }
            return t - piece;
        }
        // Cruise until the stopping distance is what is left.
        let cruise = ((dist - stopping) / v.max(VELOCITY_EPS)).max(0.0);
        let piece = cruise.min(t);
        self.pos += dir * v * piece;
        self.vel = dir * v;
        if piece >= cruise {
            // Exactly at the point where the deceleration begins.
            self.pos = target - dir * stopping;
        }
        t - piece
    }

    fn arrive(&mut self, target: f64) {
        self.pos = target;
        self.vel = 0.0;
        self.goal = Goal::Hold;
        self.move_timer = false;
        if self.homing == Homing::PostTrigger {
            // PMAC-SRM p.82 (Ix26): the motor stops Ixx26 from the trigger position "and call[s]
            // this commanded location as motor position zero".
            self.homing = Homing::None;
            self.origin = target;
            self.home_complete = true;
        }
    }

    fn trigger(&mut self, home_target: f64) {
        self.homing = Homing::PostTrigger;
        self.home_target = home_target;
        let speed = match self.goal {
            Goal::Velocity { v } => v.abs(),
            _ => self.vel.abs(),
        };
        self.goal = Goal::Position { target: home_target, speed };
    }

    fn step(&mut self, t: f64, a: f64) {
        self.pos += self.vel * t + a * t * t / 2.0;
        self.vel += a * t;
    }
}

/// The first time in `0..=within` ms at which a motion from `pos` at `vel` accelerating at `a`
/// reaches `at`; `None` when it does not.
fn crossing(pos: f64, vel: f64, a: f64, at: f64, within: f64) -> Option<f64> {
    let d = at - pos;
    let roots: [Option<f64>; 2] = if a == 0.0 {
        [(vel != 0.0).then(|| d / vel), None]
    } else {
        let disc = vel * vel + 2.0 * a * d;
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        [Some((-vel + s) / a), Some((-vel - s) / a)]
    };
    roots.into_iter().flatten().filter(|r| r.is_finite() && (0.0..=within).contains(r)).reduce(f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(a: &mut Axis, ms: f64, step: f64) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        let mut t = 0.0;
        while t < ms {
            a.advance(step, None, 0.0, &Limits::NONE);
            out.push((a.pos, a.vel));
            t += step;
        }
        out
    }

    #[test]
    fn a_jog_to_a_position_arrives_exactly_and_never_exceeds_its_speed_or_acceleration() {
        let mut a = Axis::default();
        a.jog(Some(2000.0), 1.0, 0.5, 0.005);
        let samples = run(&mut a, 10_000.0, 0.4427);
        assert_eq!(a.pos, 2000.0);
        assert!(a.at_rest());
        assert!(!a.move_timer);
        let mut last = 0.0;
        for (p, v) in samples {
            assert!((-1e-12..=0.5 + 1e-9).contains(&v), "{v}");
            assert!(p + 1e-9 >= last, "never backwards: {p} after {last}");
            last = p;
        }
        // 2000 counts at 0.5 counts/ms, 100 ms to reach that speed: 4,100 ms in all.
        let mut b = Axis::default();
        b.jog(Some(2000.0), 1.0, 0.5, 0.005);
        b.advance(4_099.0, None, 0.0, &Limits::NONE);
        assert!(!b.at_rest(), "still moving at 4,099 ms: {b:?}");
        b.advance(1.0 + 1e-6, None, 0.0, &Limits::NONE);
        assert!(b.at_rest() && b.pos == 2000.0, "{b:?}");
    }

    #[test]
    fn one_advance_equals_many_small_ones() {
        let mut one = Axis::default();
        one.jog(Some(-750.0), -1.0, 2.0, 0.01);
        let mut many = one;
        one.advance(300.0, None, 0.0, &Limits::NONE);
        for _ in 0..3000 {
            many.advance(0.1, None, 0.0, &Limits::NONE);
        }
        assert!((one.pos - many.pos).abs() < 1e-6, "{} {}", one.pos, many.pos);
        assert!((one.vel - many.vel).abs() < 1e-9);
    }

    #[test]
    fn a_stop_within_a_time_ends_at_rest_then_and_not_before() {
        let mut a = Axis::default();
        a.jog(None, 1.0, 32.0, 0.15625);
        a.advance(1000.0, None, 0.0, &Limits::NONE);
        assert_eq!(a.vel, 32.0);
        a.stop_within(10.0);
        a.advance(9.9, None, 0.0, &Limits::NONE);
        assert!(a.vel > 0.0);
        a.advance(0.1 + 1e-9, None, 0.0, &Limits::NONE);
        assert!(a.at_rest(), "{a:?}");
    }

    #[test]
    fn a_homing_search_triggers_at_the_flag_and_makes_the_offset_position_zero() {
        let mut a = Axis::default();
        a.home(-4.0, 0.1);
        for _ in 0..1000 {
            a.advance(5.0, Some(-300.0), 20.0, &Limits::NONE);
        }
        assert!(a.home_complete && a.at_rest(), "{a:?}");
        assert!((a.pos - -280.0).abs() < 1e-9, "{}", a.pos);
        assert_eq!(a.reported_position(), 0.0);
        let mut never = Axis::default();
        never.home(4.0, 0.1);
        for _ in 0..1000 {
            never.advance(5.0, Some(-300.0), 0.0, &Limits::NONE);
        }
        assert!(!never.home_complete && never.vel == 4.0, "the flag lies behind it: it searches on");
    }

    #[test]
    fn a_reversal_comes_to_rest_first_and_arrives() {
        let mut a = Axis::default();
        a.jog(None, 1.0, 10.0, 0.1);
        a.advance(200.0, None, 0.0, &Limits::NONE);
        a.jog(Some(0.0), -1.0, 10.0, 0.1);
        a.advance(10_000.0, None, 0.0, &Limits::NONE);
        assert!(a.at_rest() && a.pos == 0.0, "{a:?}");
    }

    #[test]
    fn hostile_numbers_leave_it_finite() {
        let mut a = Axis::default();
        a.jog(Some(1e300), 1.0, 1e300, 1e300);
        a.advance(f64::INFINITY, None, 0.0, &Limits::NONE);
        a.advance(f64::NAN, None, 0.0, &Limits::NONE);
        a.advance(1e12, None, 0.0, &Limits::NONE);
        assert!(a.pos.is_finite() || a.pos == 1e300, "{a:?}");
    }

    #[test]
    fn a_software_limit_stops_a_move_past_it_at_the_limit_rate_and_not_a_move_before_it() {
        let limits = Limits { plus: Some(1000.0), minus: Some(-50.0), decel: 0.5 };
        let mut a = Axis::default();
        a.jog(Some(5000.0), 1.0, 10.0, 1.0);
        for _ in 0..1000 {
            a.advance(1.0, None, 0.0, &limits);
        }
        // Crossed at 1000 at 10 counts/ms, then 100 counts at 0.5 counts/ms².
        assert!(a.at_rest() && a.limit_stop, "{a:?}");
        assert!((a.pos - 1100.0).abs() < 1e-6, "{}", a.pos);
        let mut b = Axis::default();
        b.jog(Some(900.0), 1.0, 10.0, 1.0);
        b.advance(1000.0, None, 0.0, &limits);
        assert!(b.at_rest() && !b.limit_stop && b.pos == 900.0);
        // A homing search ignores them until its trigger (SRM p.96).
        let mut h = Axis::default();
        h.home(-10.0, 1.0);
        h.advance(100.0, Some(-500.0), 0.0, &limits);
        assert!(!h.limit_stop && h.pos < -50.0, "{h:?}");
    }
}
