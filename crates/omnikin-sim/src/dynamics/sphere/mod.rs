//! Dynamics of paper 000's spherical robot: a shell rolling on the floor, moved by an internal
//! platform on three omni-wheels driven by stepper motors.
//!
//! * [`params`]: [`SphereDynamics`], the physical parameters with their sources.
//! * [`priors`]: [`priors::PRIORS`], each value's plausible range, for the prior bands and the
//!   sensitivity table of `reproduce sphere-2019`.
//! * [`floor`]: [`FloorCoefficients`], the named floor surfaces' pivot friction, rolling
//!   resistance and friction coefficient (`floor = "vinyl"` …).
//! * `equations`: mass matrix, generalised forces, constraint rows, accelerations, projection.
//! * [`sim`]: [`SphereSim`], the constraint-keeping RK4 integrator and what each step reports.
//! * [`stepper`]: [`Stepper`], the hybrid stepper's torque–angle law, pull-out curve and lost
//!   steps (`motor = "stepper"`).
//! * [`trial`]: [`simulate_plan`], a plan through the model recorded as a [`crate::Trial`].
//! * [`monte_carlo`]: [`DynamicProfile`], seeded trial-to-trial variation for Monte Carlo, and
//!   [`fit_com_depth`], the one-parameter fit to a circle's radius ratio.
//!
//! # Derivation
//!
//! **Frames and symbols.** World frame `OXYZ`: x, y on the floor, z up, `γ = (0, 0, 1)`.
//! Platform frame `Cxyz` (paper 000 §4): origin at the shell centre `C`, z up when the platform
//! is level; `Q` (the quaternion `q`) rotates platform-frame vectors into the world frame and
//! `k = Q e3` is the platform's z axis in the world. Unless noted, vectors are in the **world**
//! frame.
//!
//! | symbol | meaning | unit |
//! |---|---|---|
//! | `R` | shell radius | m |
//! | `m_s`, `I_s` | shell mass; its moment of inertia about `C` (spherically symmetric) | kg, kg·m² |
//! | `m_p`, `J_p` | platform mass; its inertia tensor about its centre of mass, platform frame | kg, kg·m² |
//! | `J_w = Q J_p Qᵀ` | the same in the world frame | kg·m² |
//! | `h` | depth of the platform's centre of mass below `C` along `−k` | m |
//! | `M = m_s + m_p` | total mass | kg |
//! | `ω`, `Ω` | platform and shell angular velocities | rad/s |
//! | `Ω3 = Ω·γ` | shell spin about the vertical | rad/s |
//! | `s_i`, `n_i`, `R_i` | wheel `i`'s lever `r_i × α_i` (m) and axis, platform frame; wheel radius (m) — paper 000 §4, [`omnikin::sphere`] | |
//! | `σ_i = Q s_i` | the lever in the world frame | m |
//! | `κ_i = (R_i/R)(s_i·n_i)` | wheel-rate lever | m |
//! | `χ̇_i` | wheel `i`'s rate relative to the platform, right-handed about `n_i` | rad/s |
//! | `τ_p`, `ε_p` | Coulomb pivot friction torque; its regularisation scale | N·m, rad/s |
//! | `C_rr`, `ε_r` | rolling-resistance coefficient; its regularisation scale | 1, rad/s |
//! | `g` | gravity | m/s² |
//!
//! **Assumptions.** The platform's frame origin stays at `C` (the wheels hold it centred); the
//! wheels and rollers are massless (their inertia is lumped into the platform); each wheel
//! touches the shell at one point (paper 000's ideal Mecanum wheel) and transmits force only
//! along the roller axis `α_i` (plus a normal force through `C`, which has no moment about
//! `C`); the shell rolls on the horizontal floor without slipping horizontally while the floor
//! force stays inside its friction cone, and slides when it would leave it (below); the normal
//! force in the floor's pivot-friction and rolling-resistance laws is the static `M g`.
//!
//! **The shell sliding on the floor.** The floor force the rolling shell needs,
//! `F = m_s a_C + m_p a_p + M g γ`, is checked at the start of each sub-step against the cone
//! `|F_h| ≤ μ_f F_z` ([`SphereDynamics::floor_friction`]). Outside it the shell **slides**
//! ([`SphereStep::floor_slip`], a floor-slip event): the centre velocity `v` becomes a
//! generalised speed of its own, `u = (ω, Ω, v) ∈ ℝ⁸`, with the mass matrix
//! `diag-blocks(M_ωω, I_s I, M I₂)` coupled by `M_ωv = −m_p h [k]×` (the platform's centre of
//! mass moves at `v + h k × ω`; with `v = R Ω × γ` it is the rolling `M` above), and the
//! floor's horizontal force is the Coulomb force `F_t = μ_f N d` at the contact point
//! `C − R γ` (on `v`: `F_t`; on `Ω`: `−R γ × F_t`), `N = F_z` and `d` frozen over the sub-step
//! (`N` iterated to the value its own friction gives; `d` the direction of the needed force at
//! the onset, then opposite to the contact point's slip velocity `v_s = v − R Ω × γ`). The
//! slide dissipates `−F_t·v_s ≥ 0` ([`SphereStep::floor_slide_work`], counted in
//! [`SphereStep::floor_work`]); when `v_s·d` reaches 0 the floor sticks again: an impulse at
//! the contact projects `u` onto `v = R Ω × γ` in the metric of the 8 × 8 mass matrix (its
//! work, the floor's too).
//!
//! **Roller–shell contacts** (unilateral, with friction). The platform's Newton equation
//! `m_p a_p = −m_p g γ − Σ N_i p̂_i − Σ f_i α_i` (`p̂_i` the unit direction from `C` to contact
//! `i`, `f_i = λ_i (R − R_i)/R` the roller force, `a_p = R Ω̇ × γ − h ω̇ × k − h ω × (ω × k)`)
//! gives the three normal forces `N_i` that keep the platform centred (the three contact
//! directions span 3-D), plus a stated per-wheel preload
//! ([`SphereDynamics::roller_preload`]). At the start of each sub-step: a wheel whose `N_i`
//! would be ≤ 0 **lifts** (no roller force; [`SphereStep::lift_off`]); a sticking roller
//! whose force would exceed `μ N_i` ([`SphereDynamics::roller_friction`]) **slides**
//! ([`SphereStep::roller_slip`]) with the force `d μ N_i + c v` (Karnopp's stick–slip law:
//! `d` the direction the sticking force had, `v` the slip velocity along `α_i`, `c`
//! [`SphereDynamics::roller_viscous`]) until `v d` reaches 0, when it sticks again; a lifted
//! wheel lands (sliding against the slip it built up while free) once its normal force stays
//! positive with its own friction force applied. The motor's pull-out (below) is checked after
//! the contact, whichever limit is lower binds. The platform's small departures from the
//! centre that a real lift-off allows are not modelled. `N_i` is frozen within a sub-step.
//! Every step reports the work of the wheel forces (RK4 quadrature of `Σ λ_i C_i u`, plus
//! the energy the sticking impulses of the projection remove) and of the floor torque, so the
//! energy balance can be checked step by step.
//!
//! **Velocities.** The generalised speeds are `u = (ω, Ω) ∈ ℝ⁶`. Rolling without slip at the
//! floor contact `−R γ`, `v_C + Ω × (−R γ) = 0`, gives the shell centre's velocity
//! `v_C = R Ω × γ = A Ω` with `A = −R [γ]×` (paper 000 eq. 5.1, the physical solution of
//! erratum E1); the platform's centre of mass at `C − h k` moves at
//! `v_p = A Ω + B ω` with `B = h [k]×`. The rolling constraint is nonholonomic; it is built
//! into the speeds (the floor's contact force does no work and drops out), and the shell's
//! orientation is not needed (the shell is spherically symmetric).
//!
//! **Kane's equations** (equivalent to Lagrange–d'Alembert for these speeds):
//! `Σ_bodies L_bᵀ (F_b − m_b a_b) + W_bᵀ (T_b − Ḣ_b) = 0`, with the partial velocities
//! `L_s = (0, A)`, `W_s = (0, I)` for the shell and `L_p = (B, A)`, `W_p = (I, 0)` for the
//! platform, give
//!
//! ```text
//! M(q) u̇ = f(q, u) + Σ_i λ_i C_iᵀ
//!
//! M = ⎡ m_p h² (I − k kᵀ) + J_w              m_p h R (γ kᵀ − (k·γ) I) ⎤
//!     ⎣ m_p h R (k γᵀ − (k·γ) I)            M R² (I − γ γᵀ) + I_s I  ⎦
//!
//! f = ⎡ m_p g h (k × γ) + m_p h k × b − ω × J_w ω ⎤     b = h (ω × k) × ω
//!     ⎣ τ_floor − m_p R γ × b                     ⎦
//!
//! τ_floor = −τ_p tanh(Ω3/ε_p) γ − C_rr M g R Ω_h / √(|Ω_h|² + ε_r²)
//! ```
//!
//! (`Ω_h` the horizontal part of `Ω`; gravity on the shell does no work, the platform's gives
//! the pendulum torque `m_p g h k × γ`; `b` is the platform centre of mass's centripetal
//! acceleration relative to `C`; the shell's `Ω × I_s Ω` vanishes.) `M` is symmetric positive
//! definite: it is `Σ m L_bᵀ L_b + diag(J_w, I_s I)`.
//!
//! **Wheels and motors.** Paper 000 eq. 4.4 holds in the platform frame in any orientation:
//! `s_i·(Qᵀ(Ω − ω)) = κ_i χ̇_i`, i.e. `C_i u = κ_i χ̇_i` with the row `C_i = (−σ_iᵀ, σ_iᵀ)`.
//! The roller of wheel `i` pushes the shell with a force `f_i` along `α_i` at the contact
//! point `p_i = r_i R/(R − R_i)`: a torque `f_i (R/(R − R_i)) σ_i` on the shell and its
//! opposite on the platform, so `λ_i = f_i R/(R − R_i)`. The massless wheel's moment balance
//! about `n_i` gives the **motor torque** `τ_i = κ_i λ_i` (and the motor's power `τ_i χ̇_i`
//! equals the constraint's `λ_i C_i u`, a check). A powered stepper imposes `χ̇_i(t)`: a
//! rheonomic constraint `C_i u = κ_i χ̇_i(t)` (holonomic for the relative orientation), so
//! `C_i u̇ = κ_i χ̈_i − Ċ_i u` with `Ċ_i u = (ω × σ_i)·(Ω − ω)`. With `Y = M⁻¹ Cᵀ`,
//! `S = C Y`: `S λ = κ χ̈ − Ċ u − C M⁻¹ f` and `u̇ = M⁻¹ f + Y λ`.
//! * **Pull-out**: a motor whose `|τ_i|` would exceed the pull-out torque `τ_max` leaves the
//!   constraint and delivers `τ_i = ±τ_max` in the direction it was pushing (row `i` of `S`
//!   replaced by `λ_i = ±τ_max/|κ_i|`) until its actual rate `C_i u/κ_i` has caught up with
//!   the command; it then locks again (a slipping clutch: a stepper that loses steps and
//!   resynchronises; lost steps do not matter here because rates, not angles, are imposed).
//!   [`SphereStep::pull_out`] reports each such event.
//! * **Steppers** (`motor = "stepper"`, [`stepper`]): no wheel is locked; each motor's
//!   `λ_i = τ_i/κ_i` comes from the hybrid stepper's torque–angle law against the commanded
//!   angle (the integral of the ramped rate), its amplitude the pull-out torque at the field's
//!   speed; a rotor that slips a pole loses 4 full steps per electrical cycle
//!   ([`SphereStep::lost_steps`]) and is not resynchronised. The motors' work and the sliding
//!   rollers' loss are reported per step ([`SphereStep::motor_work`],
//!   [`SphereStep::slip_work`]): `ΔE = W_motor − W_slip + W_floor`.
//! * **Unpowered** ([`SphereSim::coast`]): `λ = 0`, the wheels turn freely; platform and shell
//!   exchange no torque and the mechanical energy `E = ½ uᵀ M u − m_p g h (k·γ)` is conserved
//!   when `τ_floor = 0`.
//! * **Motors holding fixed rates**: the constraint forces do work `Σ λ_i κ_i χ̇_i`, zero for
//!   `χ̇ = 0`, so `E` is conserved too. With `χ̇ = 0` the robot is one rigid body: the
//!   rocking frequency about the floor contact for small tilts is
//!   `ω² = m_p g h / (I_s + m_s R² + I_p + m_p (R − h)²)` ([`SphereDynamics::rocking_frequency`]).
//!
//! **What follows from these equations (the tests check each).** Vertical angular momentum
//! about the floor contact, `J_w,zz ω_z + I_s Ω3` for a level platform, changes only by
//! `τ_floor·γ`: a start that imposes a relative yaw `−ω0` splits it into a platform yaw rate
//! `ω0 I_s/(I_s + J_p,zz)` and a shell counter-spin, which the pivot friction then removes. In
//! a steady acceleration `a` along x the moment balance about `C` gives a forward lean `θ` with
//! `m_p g h sin θ = a (M R − m_p h cos θ + I_s/R)`, i.e.
//! `m_p h sin θ = (a/g)(M z_cm + I_s/R)` with `z_cm = R − m_p h cos θ / M`.
//!
//! **The lean grows a circle** (an emergent result; the seed digest's first-order note has the
//! opposite sign). In a circle of radius `r` at speed `v` (`ω0 = v/r`) the centre of mass,
//! `h` *below* the shell centre, must move *inward* by the lean `θ` above, so the platform's
//! z axis (its top) tilts *outward*. The wheels impose `ω̃ = (0, v/R, −ω0)` about the tilted
//! platform axes: in the world that is a roll `(v/R) cos θ + ω0 sin θ` about the horizontal
//! and `(v/R) sin θ − ω0 cos θ` about the vertical. With the shell's spin held by the pivot
//! friction (`Ω3 ≈ 0`) the shell rolls at `v cos θ + R ω0 sin θ` and the platform turns at
//! `ω0 cos θ − (v/R) sin θ`: the radius becomes
//! `r (cos θ + (R/r) sin θ)/(cos θ − (r/R) sin θ) ≈ r (1 + (R/r + r/R) θ)`. For the paper's
//! 0.2 m circle with the default parameters: 1.018 at 0.1 m/s and 1.07 at 0.2 m/s from the
//! quasi-static lean alone (a test checks the simulated 0.1 and 0.2 m/s smooth circles against
//! it). At 0.4 and 0.5 m/s the lean taken from the planned `a = v²/r` (≈ 1.35 and ≈ 1.65)
//! overstates it: the larger circle lowers the actual centripetal acceleration `v′ω′`, and the
//! self-consistent steady state (an independent derivation, with the platform's own precession
//! terms) gives ≈ 1.30 and ≈ 1.48 — the steady lean alone does not reach the paper's 1.4 and
//! 1.6; the full-speed start's transient does the rest in the simulation. A top tilted *inward* would shrink
//! the circle; that is the digest's `v cos θ − R ω0 sin θ`, which inverts the pendulum.
//!
//! **Integration.** State `(q, ω, Ω, x_C, y_C, χ)`; classical RK4 at fixed sub-steps
//! (≤ [`SphereDynamics::max_substep`]) with the motor modes frozen inside a sub-step and the
//! command ramped linearly over each [`SphereSim::step`]; after each sub-step `q` is normalised
//! and `u` is projected onto the locked wheels' constraints in the metric of `M`
//! (`u ← u − Y (C Y)⁻¹ (C u − κ χ̇)`, the smallest kinetic-energy correction), so the wheel
//! constraints hold to rounding; the floor constraint holds by construction while the shell
//! rolls (and by the sticking impulse when a slide ends). Fixed-size
//! `nalgebra` matrices only: no allocation per step, and a fixed sequence of operations, so
//! the results do not depend on threads or the machine's load.
//!
//! Reference family: Karavaev & Kilin, "The dynamics and control of a spherical robot with an
//! internal omniwheel platform", Regular and Chaotic Dynamics 20 (2015); the seed digest's
//! "Dynamics notes".

mod equations;
pub mod floor;
pub mod monte_carlo;
pub mod params;
pub mod priors;
pub mod robot_file;
pub mod sim;
pub mod stepper;
pub mod trial;

pub use floor::FloorCoefficients;
pub use monte_carlo::{DynamicFit, DynamicProfile, fit_com_depth, radius_ratio};
pub use params::{DynamicsError, SphereDynamics, floor_note, floor_override_note};
pub use robot_file::{com_depth_comment, write_fitted_com_depth};
pub use sim::{ContactEvents, Residuals, SphereSim, SphereState, SphereStep};
pub use stepper::Stepper;
pub use trial::{ContactEvent, ContactEventKind, DynamicTrial, simulate_plan};
