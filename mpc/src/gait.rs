//! Gait schedules in the style of the MIT Cheetah controller (Di Carlo et al. 2018,
//! `OffsetDurationGait`): every leg `i` has a phase offset `oᵢ` and a stance fraction (duty
//! factor) `dᵢ` of a common period `T`. With the global phase `φ ∈ [0, 1)` the leg's own
//! phase is `ψᵢ = (φ − oᵢ) mod 1`; the leg is in stance while `ψᵢ < dᵢ` (stance progress
//! `ψᵢ / dᵢ`) and in swing otherwise (swing progress `(ψᵢ − dᵢ) / (1 − dᵢ)`).
//!
//! Leg order is the robot's contact-leg order: for quadrupeds front-left, front-right,
//! hind-left, hind-right (Solo's FL, FR, HL, HR); for bipeds left, right.
//!
//! Transitions ([`GaitScheduler`]): a new gait takes over at the next cycle boundary
//! (`φ` wrapping to 0), the moment at which, in every table below, each leg is either
//! starting its stance or in a phase both gaits agree on as closely as the tables allow;
//! leaving [`Gait::Stand`] happens at once with `φ = 0`. Speed changes are rate-limited by
//! [`ramp`].

/// Largest number of legs a gait table describes.
pub const MAX_LEGS: usize = 4;

/// Largest stagger of the trot's diagonal partners ([`GaitPattern::staggered`]), as a
/// fraction of the cycle: each stance is then 0.3 of it, 0.2 on one foot at each end.
pub const MAX_STAGGER: f64 = 0.2;

/// The range of a gait clock's rate ([`GaitScheduler::set_rate`]): from a quarter of the
/// gait's own cadence to four times it.
pub const GAIT_RATE_RANGE: (f64, f64) = (0.25, 4.0);

/// How fast (per second) the gait clock's rate follows its target
/// ([`GaitScheduler::set_rate`]): a noisy target, as a learner's exploration gives, moves
/// the clock by at most this much per second, so the footholds and swings planned from the
/// period do not jump from tick to tick.
pub const GAIT_RATE_SLEW: f64 = 2.0;

/// The largest shift of the stance fractions ([`GaitScheduler::set_duty_shift`]): a trot's
/// ½ may go from 0.2 (a flying trot, both pairs in the air for 0.3 of the cycle) to 0.8.
pub const MAX_DUTY_SHIFT: f64 = 0.3;

/// Whether `shift` is a shift of the stance fractions the controller takes as given: finite
/// and within ±[`MAX_DUTY_SHIFT`] ([`GaitScheduler::set_duty_shift`] clamps any other). The
/// callers that refuse a bad one instead (`centaur control`, a hybrid's duty span, Python)
/// check with it.
pub fn duty_shift_in_range(shift: f64) -> bool {
    shift.is_finite() && shift.abs() <= MAX_DUTY_SHIFT
}

/// The range a shifted stance fraction is held in ([`GaitScheduler::set_duty_shift`]).
pub const DUTY_RANGE: (f64, f64) = (0.2, 0.9);

/// How fast (per second) the stance fractions' shift follows its target
/// ([`GaitScheduler::set_duty_shift`]): 0.5 → 0.35 takes 0.15 s, a noisy target moves every
/// leg's lift-off by at most 0.01 of its cycle per 10 ms tick.
pub const DUTY_SHIFT_SLEW: f64 = 1.0;

/// A named gait (recorded as its lower-case [`Gait::name`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Gait {
    /// All legs in stance.
    #[default]
    Stand,
    /// Quadruped: lateral-sequence static walk (hind-left, front-left, hind-right,
    /// front-right; three feet always down). Biped: alternating walk with double support.
    Walk,
    /// Diagonal pairs together (FL+HR, FR+HL).
    Trot,
    /// Lateral pairs together (FL+HL, FR+HR).
    Pace,
    /// Front pair, then hind pair.
    Bound,
    /// All four legs together, with a flight phase.
    Pronk,
    /// Rotary gallop (MIT Cheetah offsets).
    Gallop,
}

impl Gait {
    /// Every gait, for tests and command-line parsing.
    pub const ALL: [Gait; 7] =
        [Gait::Stand, Gait::Walk, Gait::Trot, Gait::Pace, Gait::Bound, Gait::Pronk, Gait::Gallop];

    /// Lower-case name (`"trot"`).
    pub fn name(&self) -> &'static str {
        match self {
            Gait::Stand => "stand",
            Gait::Walk => "walk",
            Gait::Trot => "trot",
            Gait::Pace => "pace",
            Gait::Bound => "bound",
            Gait::Pronk => "pronk",
            Gait::Gallop => "gallop",
        }
    }

    /// Parses [`Gait::name`].
    pub fn from_name(name: &str) -> Option<Gait> {
        Gait::ALL.iter().copied().find(|g| g.name() == name)
    }

    /// Position in [`Gait::ALL`].
    pub fn index(&self) -> usize {
        match self {
            Gait::Stand => 0,
            Gait::Walk => 1,
            Gait::Trot => 2,
            Gait::Pace => 3,
            Gait::Bound => 4,
            Gait::Pronk => 5,
            Gait::Gallop => 6,
        }
    }

    /// Whether the gait is defined for a robot with `n_legs` legs (2 or 4).
    pub fn supported(&self, n_legs: usize) -> bool {
        GaitPattern::new(*self, n_legs).is_some()
    }
}

/// Offsets, duty factors and period of one gait.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaitPattern {
    /// The gait.
    pub gait: Gait,
    /// Number of legs used (entries past it are ignored).
    pub n_legs: usize,
    /// Phase offset `oᵢ ∈ [0, 1)` of each leg.
    pub offsets: [f64; MAX_LEGS],
    /// Stance fraction `dᵢ ∈ (0, 1]` of each leg.
    pub duty: [f64; MAX_LEGS],
    /// Cycle period `T` (s).
    pub period: f64,
    /// The stagger of the trot's diagonal partners ([`GaitPattern::staggered`]; 0: none).
    pub stagger: f64,
}

impl GaitPattern {
    /// The table entry of `gait` for `n_legs` legs (`None` if the gait is not defined for
    /// that many legs). Quadruped values follow the MIT Cheetah tables (10 segments per
    /// cycle: trot offsets 0/5/5/0 with durations 5, bound 5/5/0/0 and 4, pronk 0 and 4,
    /// pace 5/0/5/0 and 5, gallop 0/2/7/9 and 4), re-ordered from MIT's FR, FL, HR, HL to
    /// FL, FR, HL, HR; the walk is a static lateral-sequence walk with duty 0.75.
    pub fn new(gait: Gait, n_legs: usize) -> Option<GaitPattern> {
        let p = |offsets: [f64; 4], duty: [f64; 4], period: f64| GaitPattern {
            gait,
            n_legs,
            offsets,
            duty,
            period,
            stagger: 0.0,
        };
        match (n_legs, gait) {
            (4, Gait::Stand) => Some(p([0.0; 4], [1.0; 4], 0.5)),
            // Lateral sequence HL (0), FL (0.25), HR (0.5), FR (0.75).
            (4, Gait::Walk) => Some(p([0.25, 0.75, 0.0, 0.5], [0.75; 4], 0.8)),
            (4, Gait::Trot) => Some(p([0.0, 0.5, 0.5, 0.0], [0.5; 4], 0.3)),
            (4, Gait::Pace) => Some(p([0.0, 0.5, 0.0, 0.5], [0.5; 4], 0.3)),
            (4, Gait::Bound) => Some(p([0.0, 0.0, 0.5, 0.5], [0.4; 4], 0.3)),
            (4, Gait::Pronk) => Some(p([0.0; 4], [0.4; 4], 0.3)),
            // MIT: FR 0, FL 0.2, HR 0.7, HL 0.9.
            (4, Gait::Gallop) => Some(p([0.2, 0.0, 0.9, 0.7], [0.4; 4], 0.4)),
            (2, Gait::Stand) => Some(p([0.0; 4], [1.0; 4], 0.5)),
            // Duty 0.6: two double-support phases of 10 % of the cycle each.
            (2, Gait::Walk) => Some(p([0.0, 0.5, 0.0, 0.0], [0.6, 0.6, 1.0, 1.0], 0.8)),
            _ => None,
        }
    }

    /// The pattern with every leg's stance fraction `duty` instead of its table's
    /// (`duty ∈ (0, 1)`; otherwise, and for [`Gait::Stand`], returned unchanged). The phase
    /// offsets stay, so each leg still lifts off in the table's order; below ½ a biped's
    /// or a trot's stances no longer overlap (flight phases in the schedule).
    pub fn with_duty(mut self, duty: f64) -> GaitPattern {
        if self.gait != Gait::Stand && duty > 0.0 && duty < 1.0 {
            self.duty[..self.n_legs].fill(duty);
        }
        self
    }

    /// The pattern with the trot's diagonal partners staggered by `s` of the cycle for
    /// turning (`|s|` ≤ [`MAX_STAGGER`], clamped): positive `s` (a left turn) lets the left
    /// legs lead their pairs (FL before HR, HL before FR), negative the right legs, and every
    /// stance shortens to `0.5 − |s|`. Each pair's stance then opens with the leading foot
    /// alone and closes with the trailing one alone. Without abduction a foot pair in contact
    /// cannot yaw (the feet would have to slide sideways in the body frame), but on one foot
    /// the body can, and the fore-aft force of that foot, offset sideways from the centre of
    /// mass, turns it: braking on the inner front foot as its stance opens and pushing with
    /// the outer hind foot as it closes both yaw toward the inside. Other gaits, and `s = 0`,
    /// are returned unchanged.
    pub fn staggered(mut self, s: f64) -> GaitPattern {
        let s = if s.is_finite() { s.clamp(-MAX_STAGGER, MAX_STAGGER) } else { 0.0 };
        if self.gait != Gait::Trot || self.n_legs != 4 || s == 0.0 {
            return self;
        }
        let d = s.abs();
        // Legs FL 0, FR 1, HL 2, HR 3: (leader, trailer) of the pair starting at 0 and of
        // the pair starting at 0.5.
        let ((a_lead, a_trail), (b_lead, b_trail)) =
            if s > 0.0 { ((0, 3), (2, 1)) } else { ((3, 0), (1, 2)) };
        self.offsets[a_lead] = 0.0;
        self.offsets[a_trail] = d;
        self.offsets[b_lead] = 0.5;
        self.offsets[b_trail] = 0.5 + d;
        self.duty = [0.5 - d; 4];
        self.stagger = s;
        self
    }

    /// The leg's own phase `ψᵢ = (φ − oᵢ) mod 1`.
    #[inline]
    pub fn leg_phase(&self, phase: f64, leg: usize) -> f64 {
        wrap01(phase - self.offsets[leg])
    }

    /// Whether leg `leg` is in stance at global phase `phase`.
    #[inline]
    pub fn in_stance(&self, phase: f64, leg: usize) -> bool {
        self.leg_phase(phase, leg) < self.duty[leg]
    }

    /// Stance progress in `[0, 1)` (`None` in swing).
    #[inline]
    pub fn stance_progress(&self, phase: f64, leg: usize) -> Option<f64> {
        let psi = self.leg_phase(phase, leg);
        (psi < self.duty[leg]).then(|| psi / self.duty[leg])
    }

    /// Swing progress in `[0, 1)` (`None` in stance).
    #[inline]
    pub fn swing_progress(&self, phase: f64, leg: usize) -> Option<f64> {
        let psi = self.leg_phase(phase, leg);
        (psi >= self.duty[leg]).then(|| (psi - self.duty[leg]) / (1.0 - self.duty[leg]))
    }

    /// Stance duration `dᵢ T` (s).
    #[inline]
    pub fn stance_duration(&self, leg: usize) -> f64 {
        self.duty[leg] * self.period
    }

    /// Swing duration `(1 − dᵢ) T` (s).
    #[inline]
    pub fn swing_duration(&self, leg: usize) -> f64 {
        (1.0 - self.duty[leg]) * self.period
    }
}

/// `x mod 1` in `[0, 1)`.
#[inline]
pub fn wrap01(x: f64) -> f64 {
    let r = x - x.floor();
    if r >= 1.0 { 0.0 } else { r }
}

/// Moves `current` toward `target` by at most `max_step` (a rate limiter: with
/// `max_step = a_max · dt` it ramps a commanded speed at acceleration `a_max`).
#[inline]
pub fn ramp(current: f64, target: f64, max_step: f64) -> f64 {
    current + (target - current).clamp(-max_step, max_step)
}

/// Global gait phase with phase-consistent gait switching.
#[derive(Clone, Debug)]
pub struct GaitScheduler {
    n_legs: usize,
    /// Period scale per gait ([`Gait::index`]); 0: the gait is not run.
    period_scales: [f64; Gait::ALL.len()],
    /// Stance fraction of every leg per gait ([`Gait::index`]), replacing the table's; 0:
    /// the table's.
    duty_factors: [f64; Gait::ALL.len()],
    pattern: GaitPattern,
    pending: Option<GaitPattern>,
    /// Stagger for turning ([`GaitPattern::staggered`]) the next cycle takes.
    stagger: f64,
    /// Multiplies the period of a staggered pattern.
    stagger_period_scale: f64,
    phase: f64,
    last_t: Option<f64>,
    /// The rate the clock runs at (1: every gait at its own period); the pattern in force
    /// and the pending one carry it in their periods.
    rate: f64,
    /// The rate the clock moves towards at [`GAIT_RATE_SLEW`].
    rate_target: f64,
    /// The shift of every stepping gait's stance fractions in force
    /// ([`GaitScheduler::set_duty_shift`]; 0: the gaits' own).
    duty_shift: f64,
    /// The shift the stance fractions move towards at [`DUTY_SHIFT_SLEW`].
    duty_shift_target: f64,
}

impl GaitScheduler {
    /// A scheduler for `n_legs` legs (2 or 4), standing, with every period multiplied by
    /// `period_scale`.
    ///
    /// # Panics
    /// If `n_legs` is neither 2 nor 4 (a programming error; the controller validates it).
    #[track_caller]
    pub fn new(n_legs: usize, period_scale: f64) -> Self {
        Self::with_period_scales(n_legs, [period_scale; Gait::ALL.len()])
    }

    /// A scheduler whose gait `g` runs at `period_scales[g.index()]` times its table period;
    /// a gait whose scale is 0 (or not positive) is not run: requests for it are ignored as
    /// for a gait not defined for this number of legs. Stand is always run (at scale 1 if
    /// its entry is 0).
    ///
    /// # Panics
    /// If `n_legs` is neither 2 nor 4 (a programming error; the controller validates it).
    #[track_caller]
    pub fn with_period_scales(n_legs: usize, mut period_scales: [f64; Gait::ALL.len()]) -> Self {
        let mut pattern = GaitPattern::new(Gait::Stand, n_legs)
            .unwrap_or_else(|| panic!("GaitScheduler: {n_legs} legs (expected 2 or 4)"));
        let stand = Gait::Stand.index();
        if period_scales[stand].is_nan() || period_scales[stand] <= 0.0 {
            period_scales[stand] = 1.0;
        }
        pattern.period *= period_scales[stand];
        Self {
            n_legs,
            period_scales,
            duty_factors: [0.0; Gait::ALL.len()],
            pattern,
            pending: None,
            stagger: 0.0,
            stagger_period_scale: 1.0,
            phase: 0.0,
            last_t: None,
            rate: 1.0,
            rate_target: 1.0,
            duty_shift: 0.0,
            duty_shift_target: 0.0,
        }
    }

    /// The same scheduler with gait `g`'s legs in stance for `duty_factors[g.index()]` of
    /// its cycle instead of its table's stance fractions ([`GaitPattern::with_duty`]); an
    /// entry outside (0, 1) keeps the table's, and so does Stand.
    pub fn with_duty_factors(mut self, duty_factors: [f64; Gait::ALL.len()]) -> Self {
        self.duty_factors = duty_factors;
        self
    }

    /// The pattern of `gait` as this scheduler runs it (its period scale and stance
    /// fraction), or `None` if the gait is not defined for this many legs or not run.
    fn table(&self, gait: Gait) -> Option<GaitPattern> {
        let scale = self.period_scales[gait.index()];
        if scale.is_nan() || scale <= 0.0 {
            return None;
        }
        let mut p = GaitPattern::new(gait, self.n_legs)?;
        p.period *= scale;
        if self.rate != 1.0 {
            p.period /= self.rate;
        }
        Some(p.with_duty(self.duty_factors[gait.index()]))
    }

    /// The pattern in force.
    pub fn pattern(&self) -> &GaitPattern {
        &self.pattern
    }

    /// The gait that will take over at the next cycle boundary, if any.
    pub fn pending(&self) -> Option<Gait> {
        self.pending.map(|p| p.gait)
    }

    /// Global phase `φ ∈ [0, 1)`.
    pub fn phase(&self) -> f64 {
        self.phase
    }

    /// Number of legs.
    pub fn n_legs(&self) -> usize {
        self.n_legs
    }

    /// Sets the trot's stagger for turning ([`GaitPattern::staggered`]); it takes effect
    /// at the next cycle boundary, as a gait switch does, so that no leg's contact jumps.
    pub fn set_stagger(&mut self, stagger: f64) {
        self.stagger = stagger;
    }

    /// Multiplies the period of staggered patterns by `scale` (1 at construction; a
    /// non-finite or non-positive scale counts as 1). Like the stagger, it takes effect at
    /// the next cycle boundary.
    pub fn set_stagger_period_scale(&mut self, scale: f64) {
        self.stagger_period_scale = if scale.is_finite() && scale > 0.0 { scale } else { 1.0 };
    }

    /// `p` with the stagger in force and, if that staggers it, the staggered period, and
    /// then the stance fractions' shift in force.
    fn turning(&self, p: GaitPattern) -> GaitPattern {
        let mut q = p.staggered(self.stagger);
        if q.stagger != 0.0 {
            q.period *= self.stagger_period_scale;
        }
        self.shifted(q)
    }

    /// `p` with every leg's stance fraction moved by the shift in force and held in
    /// [`DUTY_RANGE`]; the stand, and any pattern without a shift, unchanged.
    fn shifted(&self, mut p: GaitPattern) -> GaitPattern {
        if self.duty_shift != 0.0 && p.gait != Gait::Stand {
            let (low, high) = DUTY_RANGE;
            for d in &mut p.duty[..p.n_legs] {
                *d = (*d + self.duty_shift).clamp(low, high);
            }
        }
        p
    }

    /// Sets how far every stepping gait's stance fractions are moved from their own
    /// (`d = d₀ + shift`, held in [`DUTY_RANGE`]): below 0 the feet leave the ground
    /// sooner and a trot gets flight phases, as a running animal's do; above 0 they stay
    /// longer. The shift follows at [`DUTY_SHIFT_SLEW`] and acts on the pattern in force at
    /// once, each leg's phase carrying on, so a leg near the end of its stance may lift off
    /// (or one just lifted touch down again) a little sooner than planned, but no swing or
    /// stance restarts. Clamped to ±[`MAX_DUTY_SHIFT`]; a non-finite shift counts as 0, and a
    /// reset goes back to 0. A staggered (turning) trot's fractions are shifted from the
    /// stagger's. The stand has no stance fraction to move.
    pub fn set_duty_shift(&mut self, shift: f64) {
        self.duty_shift_target =
            if shift.is_finite() { shift.clamp(-MAX_DUTY_SHIFT, MAX_DUTY_SHIFT) } else { 0.0 };
    }

    /// The shift of the stance fractions in force now ([`GaitScheduler::set_duty_shift`]).
    pub fn duty_shift(&self) -> f64 {
        self.duty_shift
    }

    /// Shifts the stance fractions by `shift` from now on: the pattern in force takes its
    /// own fractions (its gait's as this scheduler runs it, staggered as it is) moved by
    /// `shift`; a pending gait takes the shift when it starts.
    fn apply_duty_shift(&mut self, shift: f64) {
        self.duty_shift = shift;
        if self.pattern.gait == Gait::Stand {
            return;
        }
        if let Some(own) = self.table(self.pattern.gait) {
            let own = own.staggered(self.pattern.stagger);
            self.pattern.duty = self.shifted(own).duty;
        }
    }

    /// The pattern the next cycle takes if it differs from the one in force: a pending gait,
    /// or the current gait with a new stagger.
    fn upcoming(&self) -> Option<GaitPattern> {
        match self.pending {
            Some(p) => Some(self.turning(p)),
            None => {
                let p = self.turning(self.table(self.pattern.gait)?);
                (p != self.pattern).then_some(p)
            }
        }
    }

    /// Sets the rate the gait clock runs at: 1 runs every gait at its own period, 1.5
    /// makes every cycle (swing and stance alike) take 1/1.5 of it. The clock moves towards
    /// the rate at [`GAIT_RATE_SLEW`] per second of [`GaitScheduler::update`]'s time, and
    /// the phase carries on where it is, so no leg's contact jumps; the plan (contact
    /// schedule, touchdown times, footholds) follows the period in force. The rate is
    /// clamped to [`GAIT_RATE_RANGE`]; a non-finite one counts as 1. A reset goes back to 1.
    pub fn set_rate(&mut self, rate: f64) {
        let (low, high) = GAIT_RATE_RANGE;
        self.rate_target = if rate.is_finite() { rate.clamp(low, high) } else { 1.0 };
    }

    /// The rate the clock runs at now ([`GaitScheduler::set_rate`]).
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// Runs the clock at `rate` from now on: the periods in force and pending shrink or
    /// grow by the ratio, the phase stays.
    fn apply_rate(&mut self, rate: f64) {
        let k = self.rate / rate;
        self.pattern.period *= k;
        if let Some(p) = self.pending.as_mut() {
            p.period *= k;
        }
        self.rate = rate;
    }

    /// Back to standing at phase 0 and forget the clock.
    pub fn reset(&mut self) {
        *self =
            Self::with_period_scales(self.n_legs, self.period_scales).with_duty_factors(self.duty_factors);
    }

    /// Advances the phase to time `t` and requests `gait`. A gait not defined for this
    /// number of legs, or not run by this scheduler, is ignored (the current one continues). Time going backwards or
    /// jumping more than 0.1 s restarts the clock without advancing. Returns whether the
    /// gait in force changed.
    pub fn update(&mut self, t: f64, gait: Gait) -> bool {
        let dt = match self.last_t {
            Some(t0) if t >= t0 && t - t0 <= 0.1 => t - t0,
            _ => 0.0,
        };
        self.last_t = Some(t);
        if self.rate != self.rate_target {
            self.apply_rate(ramp(self.rate, self.rate_target, GAIT_RATE_SLEW * dt));
        }
        if self.duty_shift != self.duty_shift_target {
            self.apply_duty_shift(ramp(self.duty_shift, self.duty_shift_target, DUTY_SHIFT_SLEW * dt));
        }
        if gait != self.pattern.gait {
            if let Some(p) = self.table(gait) {
                self.pending = Some(p);
            }
        } else {
            self.pending = None;
        }
        let mut changed = false;
        if self.pattern.gait == Gait::Stand
            && let Some(p) = self.pending.take()
        {
            self.pattern = self.turning(p);
            self.phase = 0.0;
            return true;
        }
        let next = self.phase + dt / self.pattern.period;
        if next >= 1.0 {
            if let Some(p) = self.upcoming() {
                // Switch at the boundary; carry the remaining time into the new period.
                changed = self.pending.take().is_some();
                let rest = (next - 1.0) * self.pattern.period;
                self.pattern = p;
                self.phase = wrap01(rest / p.period);
            } else {
                self.phase = wrap01(next);
            }
        } else {
            self.phase = next;
        }
        changed
    }

    /// The predicted contact flags at `t + k·dt` for `k = 0..out.len()`, taking a pending
    /// switch at the next boundary into account.
    pub fn contact_schedule(&self, dt: f64, out: &mut [[bool; MAX_LEGS]]) {
        for (k, row) in out.iter_mut().enumerate() {
            let (p, phase) = self.predict(k as f64 * dt);
            for (leg, c) in row.iter_mut().enumerate() {
                *c = leg < self.n_legs && p.in_stance(phase, leg);
            }
        }
    }

    /// The pattern and phase in force `tau` seconds ahead.
    pub fn predict(&self, tau: f64) -> (GaitPattern, f64) {
        let next = self.phase + tau / self.pattern.period;
        match self.pending {
            Some(p) if self.pattern.gait == Gait::Stand => {
                let q = self.turning(p);
                (q, wrap01(tau / q.period))
            }
            _ if next >= 1.0 => match self.upcoming() {
                Some(p) => (p, wrap01((next - 1.0) * self.pattern.period / p.period)),
                None => (self.pattern, wrap01(next)),
            },
            _ => (self.pattern, wrap01(next)),
        }
    }

    /// Time (s) until leg `leg` next touches down (0 if it is in stance).
    pub fn time_to_touchdown(&self, leg: usize) -> f64 {
        let p = &self.pattern;
        let psi = p.leg_phase(self.phase, leg);
        if psi < p.duty[leg] { 0.0 } else { (1.0 - psi) * p.period }
    }

    /// Time (s) left in the current stance of leg `leg` (0 if it is in swing).
    pub fn stance_time_left(&self, leg: usize) -> f64 {
        let p = &self.pattern;
        let psi = p.leg_phase(self.phase, leg);
        if psi < p.duty[leg] { (p.duty[leg] - psi) * p.period } else { 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trot_pairs_are_diagonal() {
        let p = GaitPattern::new(Gait::Trot, 4).unwrap();
        // φ = 0.1: FL ψ = 0.1 < 0.5 stance; FR ψ = (0.1 − 0.5) mod 1 = 0.6 swing;
        // HL ψ = 0.6 swing; HR ψ = 0.1 stance.
        let s: Vec<bool> = (0..4).map(|l| p.in_stance(0.1, l)).collect();
        assert_eq!(s, vec![true, false, false, true]);
        // Swing progress of FR: (0.6 − 0.5) / 0.5 = 0.2.
        assert!((p.swing_progress(0.1, 1).unwrap() - 0.2).abs() < 1e-12);
        // Stance progress of FL: 0.1 / 0.5 = 0.2.
        assert!((p.stance_progress(0.1, 0).unwrap() - 0.2).abs() < 1e-12);
    }

    #[test]
    fn a_scheduler_runs_a_gait_at_its_own_stance_fraction() {
        let p = GaitPattern::new(Gait::Walk, 2).unwrap();
        // Every used leg, offsets kept; Stand and out-of-range values unchanged.
        let q = p.with_duty(0.35);
        assert_eq!(q.duty[..2], [0.35, 0.35]);
        assert_eq!((q.offsets, q.period), (p.offsets, p.period));
        assert_eq!(q.duty[2..], p.duty[2..]);
        for d in [0.0, 1.0, 1.5, -0.1, f64::NAN] {
            assert_eq!(p.with_duty(d), p, "{d}");
        }
        let stand = GaitPattern::new(Gait::Stand, 2).unwrap();
        assert_eq!(stand.with_duty(0.5), stand);
        // Below ½ a biped's stances no longer overlap: at φ = 0.4 neither foot is down.
        assert!(!q.in_stance(0.4, 0) && !q.in_stance(0.4, 1));
        // The scheduler builds the walk with it, at its period scale, and keeps it over a reset.
        let mut duties = [0.0; Gait::ALL.len()];
        duties[Gait::Walk.index()] = 0.35;
        let mut s = GaitScheduler::new(2, 1.25).with_duty_factors(duties);
        s.update(0.0, Gait::Walk);
        assert_eq!(s.pattern().duty[..2], [0.35, 0.35]);
        assert!((s.pattern().period - 1.25 * p.period).abs() < 1e-12);
        for k in 1..=200 {
            s.update(k as f64 * 0.01, Gait::Walk);
        }
        assert_eq!(s.pattern().duty[..2], [0.35, 0.35]);
        s.reset();
        s.update(0.0, Gait::Walk);
        assert_eq!(s.pattern().duty[..2], [0.35, 0.35]);
        // Without it, the table's.
        let mut plain = GaitScheduler::new(2, 1.0);
        plain.update(0.0, Gait::Walk);
        assert_eq!(plain.pattern().duty, p.duty);
    }

    #[test]
    fn walk_keeps_three_feet_down() {
        let p = GaitPattern::new(Gait::Walk, 4).unwrap();
        for i in 0..100 {
            let phi = i as f64 / 100.0;
            let n = (0..4).filter(|&l| p.in_stance(phi, l)).count();
            assert!(n >= 3, "phase {phi}: {n} feet down");
        }
    }

    #[test]
    fn gallop_matches_mit_offsets() {
        // MIT 10 segments, FR 0, FL 2, HR 7, HL 9, duration 4: at φ = 0.35
        // FR ψ = 0.35 < 0.4 stance, FL ψ = 0.15 stance, HR ψ = 0.65 swing, HL ψ = 0.45 swing.
        let p = GaitPattern::new(Gait::Gallop, 4).unwrap();
        let s: Vec<bool> = (0..4).map(|l| p.in_stance(0.35, l)).collect();
        assert_eq!(s, vec![true, true, false, false]);
    }

    #[test]
    fn biped_walk_has_double_support() {
        let p = GaitPattern::new(Gait::Walk, 2).unwrap();
        // φ = 0.05: L ψ = 0.05 stance, R ψ = 0.55 stance (duty 0.6) → double support.
        assert!(p.in_stance(0.05, 0) && p.in_stance(0.05, 1));
        // φ = 0.3: L stance, R ψ = 0.8 swing.
        assert!(p.in_stance(0.3, 0) && !p.in_stance(0.3, 1));
        assert!(!Gait::Trot.supported(2));
    }

    #[test]
    fn wrap_and_ramp() {
        assert_eq!(wrap01(1.25), 0.25);
        assert!((wrap01(-0.25) - 0.75).abs() < 1e-15);
        assert_eq!(ramp(0.0, 1.0, 0.1), 0.1);
        assert_eq!(ramp(0.95, 1.0, 0.1), 1.0);
        assert_eq!(ramp(0.0, -1.0, 0.1), -0.1);
    }

    #[test]
    fn the_gait_clock_runs_at_the_rate_it_is_set_to_reached_at_its_slew() {
        let walk = GaitPattern::new(Gait::Walk, 2).unwrap();
        let dt = 0.01;
        let run = |rate: f64, seconds: f64| {
            let mut s = GaitScheduler::new(2, 1.0);
            s.set_rate(rate);
            s.update(0.0, Gait::Walk);
            for k in 1..=(seconds / dt).round() as usize {
                s.update(k as f64 * dt, Gait::Walk);
            }
            s
        };
        // At rate 1 the clock is the plain one, to the bit.
        let mut plain = GaitScheduler::new(2, 1.0);
        let one = run(1.0, 0.5);
        plain.update(0.0, Gait::Walk);
        for k in 1..=50 {
            plain.update(k as f64 * dt, Gait::Walk);
        }
        assert_eq!((one.phase(), one.pattern().period), (plain.phase(), plain.pattern().period));
        // The rate moves at GAIT_RATE_SLEW per second: 1 → 1.5 in 0.25 s; the period in force
        // shrinks with it and the phase has advanced by ∫ rate dt / T.
        let fast = run(1.5, 0.5);
        assert!((fast.rate() - 1.5).abs() < 1e-12, "{}", fast.rate());
        assert!((fast.pattern().period - walk.period / 1.5).abs() < 1e-12);
        // ∫ rate over 0.5 s: 0.25 s ramping from 1 to 1.5 (mean 1.25, in steps of 0.02 per
        // tick: 0.3125 + the first tick's lag) + 0.25 s at 1.5.
        let advanced: f64 = (1..=50).map(|k| (1.0 + GAIT_RATE_SLEW * dt * k as f64).min(1.5) * dt).sum();
        assert!((fast.phase() - advanced / walk.period).abs() < 1e-9, "{} {}", fast.phase(), advanced);
        // Its contact plan follows the period in force: a touchdown comes sooner.
        let (p, _) = fast.predict(0.0);
        assert_eq!(p.period, fast.pattern().period);
        // Clamped to its range; a non-finite rate counts as 1; a reset goes back to 1.
        let mut s = run(100.0, 3.0);
        assert_eq!(s.rate(), GAIT_RATE_RANGE.1);
        s.reset();
        assert_eq!(s.rate(), 1.0);
        s.update(0.0, Gait::Walk);
        assert_eq!(s.pattern().period, walk.period);
        assert_eq!(run(0.0, 3.0).rate(), GAIT_RATE_RANGE.0);
        assert_eq!(run(f64::NAN, 1.0).rate(), 1.0);
        // A gait switch at the boundary takes the rate in force.
        let mut s = GaitScheduler::new(4, 1.0);
        s.set_rate(2.0);
        s.update(0.0, Gait::Trot);
        for k in 1..=100 {
            s.update(k as f64 * dt, Gait::Pace);
        }
        assert_eq!(s.pattern().gait, Gait::Pace);
        let pace = GaitPattern::new(Gait::Pace, 4).unwrap();
        assert!((s.pattern().period - pace.period / 2.0).abs() < 1e-12);
    }

    #[test]
    fn the_stance_fractions_shift_at_their_slew_and_the_phase_carries_on() {
        let dt = 0.01;
        let run = |shift: f64, ticks: usize| {
            let mut s = GaitScheduler::new(4, 1.0);
            s.set_duty_shift(shift);
            s.update(0.0, Gait::Trot);
            for k in 1..=ticks {
                s.update(k as f64 * dt, Gait::Trot);
            }
            s
        };
        // No shift is the plain scheduler, to the bit.
        let (zero, plain) = (run(0.0, 57), {
            let mut s = GaitScheduler::new(4, 1.0);
            s.update(0.0, Gait::Trot);
            for k in 1..=57 {
                s.update(k as f64 * dt, Gait::Trot);
            }
            s
        });
        assert_eq!((zero.phase(), *zero.pattern()), (plain.phase(), *plain.pattern()));
        // −0.15 takes 0.15 s at DUTY_SHIFT_SLEW; the trot's ½ becomes 0.35 on every leg, the
        // offsets, period and phase untouched (the clock does not depend on the shift).
        let early = run(-0.15, 10);
        assert!((early.duty_shift() + 0.1).abs() < 1e-12, "{}", early.duty_shift());
        let flying = run(-0.15, 57);
        assert!((flying.duty_shift() + 0.15).abs() < 1e-12);
        let trot = GaitPattern::new(Gait::Trot, 4).unwrap();
        for d in flying.pattern().duty {
            assert!((d - 0.35).abs() < 1e-12, "{d}");
        }
        assert_eq!((flying.pattern().offsets, flying.pattern().period), (trot.offsets, trot.period));
        assert_eq!(flying.phase(), plain.phase());
        // Flight phases: at φ = 0.4 (after the first pair's 0.35, before the second's 0.5)
        // no foot is down; the contact plan follows the fractions in force.
        assert!((0..4).all(|l| !flying.pattern().in_stance(0.4, l)));
        let mut out = [[false; 4]; 10];
        flying.contact_schedule(0.03, &mut out);
        let (p, phase) = flying.predict(0.0);
        assert_eq!(out[0], [0, 1, 2, 3].map(|l| p.in_stance(phase, l)));
        assert_eq!(p.duty, flying.pattern().duty);
        // No switch at the boundary: the shifted trot is the one in force, and a new cycle
        // keeps it.
        assert_eq!(flying.pending(), None);
        let mut s = run(-0.15, 57);
        for k in 58..=200 {
            assert!(!s.update(k as f64 * dt, Gait::Trot));
        }
        assert!((s.pattern().duty[0] - 0.35).abs() < 1e-12);
        // Clamped to ±MAX_DUTY_SHIFT and the fractions to DUTY_RANGE (the walk's 0.75 + 0.3);
        // a non-finite shift counts as 0; a reset goes back to 0.
        assert!((run(-5.0, 100).duty_shift() + MAX_DUTY_SHIFT).abs() < 1e-12);
        assert_eq!(run(f64::NAN, 100).duty_shift(), 0.0);
        let mut w = GaitScheduler::new(4, 1.0);
        w.set_duty_shift(0.3);
        for k in 0..=30 {
            w.update(k as f64 * dt, Gait::Walk);
        }
        assert_eq!(w.pattern().duty, [DUTY_RANGE.1; 4]);
        w.reset();
        assert_eq!(w.duty_shift(), 0.0);
        w.update(0.0, Gait::Walk);
        assert_eq!(w.pattern().duty, [0.75; 4]);
        // The stand has no fraction to move; a gait it starts takes the shift in force.
        let mut s = GaitScheduler::new(4, 1.0);
        s.set_duty_shift(0.1);
        for k in 0..=20 {
            s.update(k as f64 * dt, Gait::Stand);
        }
        assert_eq!(s.pattern().duty, [1.0; 4]);
        assert!((s.duty_shift() - 0.1).abs() < 1e-12);
        s.update(0.21, Gait::Trot);
        assert!((s.pattern().duty[0] - 0.6).abs() < 1e-12);
        // A turning trot's fractions are shifted from the stagger's (0.5 − 0.1).
        let mut s = GaitScheduler::new(4, 1.0);
        s.set_stagger(0.1);
        s.set_duty_shift(-0.1);
        s.update(0.0, Gait::Trot);
        for k in 1..=40 {
            s.update(k as f64 * dt, Gait::Trot);
        }
        assert!((s.pattern().duty[0] - 0.3).abs() < 1e-12, "{:?}", s.pattern().duty);
    }

    #[test]
    fn switch_happens_at_cycle_boundary() {
        let mut s = GaitScheduler::new(4, 1.0);
        assert!(s.update(0.0, Gait::Trot), "leaving stand is immediate");
        assert_eq!(s.pattern().gait, Gait::Trot);
        // Trot period 0.3 s: at t = 0.15, φ = 0.5.
        s.update(0.075, Gait::Trot);
        s.update(0.15, Gait::Pace);
        assert!((s.phase() - 0.5).abs() < 1e-12);
        assert_eq!(s.pattern().gait, Gait::Trot);
        assert_eq!(s.pending(), Some(Gait::Pace));
        // The schedule predicts the switch: 0.18 s ahead is φ = 0.1 of the pace (FL, HL down).
        let (p, ph) = s.predict(0.18);
        assert_eq!(p.gait, Gait::Pace);
        assert!((ph - 0.1).abs() < 1e-9);
        s.update(0.225, Gait::Pace);
        assert!(s.update(0.30, Gait::Pace), "boundary reached at t = 0.3");
        assert_eq!(s.pattern().gait, Gait::Pace);
        assert!(s.phase() < 1e-9);
    }

    #[test]
    fn schedule_over_horizon() {
        let mut s = GaitScheduler::new(4, 1.0);
        s.update(0.0, Gait::Trot);
        let mut out = [[false; 4]; 10];
        s.contact_schedule(0.03, &mut out);
        // k = 0..4 → φ = 0, 0.1, …, 0.4: FL, HR down; k = 5..9 → φ ≥ 0.5: FR, HL down.
        for (k, row) in out.iter().enumerate() {
            let first = k < 5;
            assert_eq!(*row, [first, !first, !first, first], "k = {k}");
        }
        assert!((s.stance_time_left(0) - 0.15).abs() < 1e-12);
        assert!((s.time_to_touchdown(1) - 0.15).abs() < 1e-12);
    }

    #[test]
    fn gaits_scale_their_own_periods_and_unrun_gaits_are_ignored() {
        let mut scales = [0.0; Gait::ALL.len()];
        scales[Gait::Trot.index()] = 1.0;
        scales[Gait::Walk.index()] = 0.75;
        let mut s = GaitScheduler::with_period_scales(4, scales);
        assert_eq!(s.pattern().period, 0.5, "stand runs at scale 1 when its entry is 0");
        assert!(!s.update(0.0, Gait::Bound), "bound is not run");
        assert_eq!(s.pattern().gait, Gait::Stand);
        assert!(s.update(0.01, Gait::Walk));
        // The walk's table period 0.8 s at 0.75.
        assert!((s.pattern().period - 0.6).abs() < 1e-12);
        s.reset();
        assert!(s.update(0.0, Gait::Trot));
        assert_eq!(s.pattern().period, 0.3);
        for (i, g) in Gait::ALL.iter().enumerate() {
            assert_eq!(g.index(), i);
        }
    }

    #[test]
    fn time_jumps_do_not_advance() {
        let mut s = GaitScheduler::new(4, 1.0);
        s.update(0.0, Gait::Trot);
        s.update(5.0, Gait::Trot);
        assert_eq!(s.phase(), 0.0);
        s.update(4.0, Gait::Trot);
        assert_eq!(s.phase(), 0.0);
    }

    /// The stances in force at phase `phi`, as FL FR HL HR flags.
    fn stances(p: &GaitPattern, phi: f64) -> [bool; 4] {
        [0, 1, 2, 3].map(|l| p.in_stance(phi, l))
    }

    #[test]
    fn a_staggered_trot_opens_and_closes_each_stance_on_the_inner_foot_then_the_outer() {
        let trot = GaitPattern::new(Gait::Trot, 4).unwrap();
        assert_eq!(trot.staggered(0.0), trot);
        assert_eq!(trot.staggered(f64::NAN), trot);
        let stand = GaitPattern::new(Gait::Stand, 4).unwrap();
        assert_eq!(stand.staggered(0.1), stand, "only the trot is staggered");
        // A left turn, stagger 0.1: FL alone, FL + HR, HR alone; then HL alone, HL + FR, FR.
        let left = trot.staggered(0.1);
        assert_eq!(left.duty, [0.4; 4]);
        for (phi, expected) in [
            (0.05, [true, false, false, false]),
            (0.25, [true, false, false, true]),
            (0.45, [false, false, false, true]),
            (0.55, [false, false, true, false]),
            (0.75, [false, true, true, false]),
            (0.95, [false, true, false, false]),
        ] {
            assert_eq!(stances(&left, phi), expected, "left turn, phase {phi}");
        }
        // A right turn: the right legs lead (HR before FL, FR before HL).
        let right = trot.staggered(-0.1);
        assert_eq!(stances(&right, 0.05), [false, false, false, true]);
        assert_eq!(stances(&right, 0.45), [true, false, false, false]);
        assert_eq!(stances(&right, 0.55), [false, true, false, false]);
        assert_eq!(stances(&right, 0.95), [false, false, true, false]);
        // Clamped to MAX_STAGGER; the pattern records its stagger.
        assert_eq!(trot.staggered(5.0), trot.staggered(MAX_STAGGER));
        assert_eq!((trot.stagger, right.stagger, trot.staggered(-5.0).stagger), (0.0, -0.1, -MAX_STAGGER));
        // Always one or two feet down: no flight phase, no foot pair across a side.
        for k in 0..1000 {
            let n = stances(&trot.staggered(MAX_STAGGER), k as f64 / 1000.0).iter().filter(|&&c| c).count();
            assert!((1..=2).contains(&n), "{n} feet at phase {k}/1000");
        }
    }

    #[test]
    fn the_scheduler_staggers_at_the_next_cycle_boundary() {
        let mut s = GaitScheduler::new(4, 1.0);
        s.update(0.0, Gait::Trot);
        let trot = *s.pattern();
        s.set_stagger(0.1);
        s.update(0.1, Gait::Trot);
        assert_eq!(*s.pattern(), trot, "not within a cycle");
        // The prediction past the boundary already uses the staggered pattern.
        let (ahead, _) = s.predict(0.25);
        assert_eq!(ahead, trot.staggered(0.1));
        let run_to = |s: &mut GaitScheduler, from: usize, to: usize| {
            for k in from..=to {
                s.update(k as f64 * 0.01, Gait::Trot);
            }
        };
        run_to(&mut s, 11, 29);
        assert_eq!(*s.pattern(), trot, "not before the boundary at 0.3 s");
        run_to(&mut s, 30, 31);
        assert_eq!(*s.pattern(), trot.staggered(0.1));
        s.set_stagger(0.0);
        run_to(&mut s, 32, 61);
        assert_eq!(*s.pattern(), trot, "back to the table's trot at the next boundary");
    }

    #[test]
    fn a_staggered_period_scale_shortens_only_staggered_cycles() {
        let mut s = GaitScheduler::new(4, 1.0);
        s.set_stagger_period_scale(0.8);
        s.update(0.0, Gait::Trot);
        let trot = *s.pattern();
        assert_eq!(trot.period, 0.3, "not staggered: the table's period");
        s.set_stagger(0.1);
        let mut turned = trot.staggered(0.1);
        turned.period *= 0.8;
        let (ahead, _) = s.predict(0.35);
        assert_eq!(ahead, turned, "the prediction past the boundary");
        for k in 1..=31 {
            s.update(k as f64 * 0.01, Gait::Trot);
        }
        assert_eq!(*s.pattern(), turned);
        // The phase runs at the shorter period: 0.24 s is one staggered cycle.
        let phase = s.phase();
        for k in 32..=55 {
            s.update(k as f64 * 0.01, Gait::Trot);
        }
        assert!((s.phase() - phase).abs() < 1e-9, "{} vs {phase}", s.phase());
        // Not positive or not finite: no scaling.
        for bad in [0.0, -1.0, f64::NAN] {
            s.set_stagger_period_scale(bad);
            assert_eq!(s.stagger_period_scale, 1.0);
        }
    }
}
