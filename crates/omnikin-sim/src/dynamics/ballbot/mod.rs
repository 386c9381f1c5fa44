//! The ballbot's 3D nonlinear dynamics and its three planar models (paper 001; issue 15).
//!
//! **System.** A homogeneous ball (mass `m_b`, radius `R`, inertia `I_b`) rolls without slip
//! on the floor; a rigid body (mass `m_B`, principal inertia `J = diag(J_x, J_y, J_z)` about
//! its centre of mass, centre of mass at `l` along its z axis above the ball centre) rests on
//! the ball through three massless omni-wheels (paper 001's geometry: contact zenith `α`,
//! azimuths `β_i`, radius `r_w`), so it pivots about the ball centre. Units SI; world frame
//! z up, x, y on the floor (conventions.md).
//!
//! **Coordinates.** Ball-centre position `(x, y)`; body orientation quaternion `q` (body →
//! world, rotation `R_B`); generalized speeds `u = (Ω, ω)`, the ball's and the body's angular
//! velocities in the world frame; the wheel angles `ψ_i` ride along. Rolling:
//! `v_ball = P Ω = R Ω × e_z` (`ẋ = R Ω_y`, `ẏ = −R Ω_x`; the spin `Ω_z` is free). Body
//! centre of mass: `r = l R_B e_z`, `v_B = P Ω + ω × r`.
//!
//! **Wheels.** Wheel `i`'s rate is `ψ̇_i = (R/r_w) b_i · R_Bᵀ(Ω − ω)` (core
//! [`omnikin::ballbot`]; exact at any tilt since the contacts are fixed in the body). By
//! virtual power, torques `T` on the wheels act as the torque pair
//! `τ = R_B (R/r_w) Bᵀ T = R_B (R/r_w)(−Tx, −Ty, Tz)` on the ball and `−τ` on the body, with
//! `(Tx, Ty, Tz) = A(0) T` paper 001's model torques (its E2-corrected inverse maps back:
//! [`omnikin::Robot::wheel_torques`]); so `T · ψ̇ = τ · (Ω − ω)` exactly.
//!
//! **Equations (Kane).** With `[a]×` the cross-product matrix, `J_w = R_B J R_Bᵀ`,
//! `c = ω × (ω × r)`, damping `c_f` (ball absolute rate) and `c_r` (ball relative to body),
//! and an optional force `F` on the body's centre of mass:
//!
//! ```text
//! (m PᵀP + I_b 1) Ω̇ − m_B Pᵀ[r]× ω̇   = τ − m_B Pᵀc − c_f Ω − c_r (Ω − ω) + Pᵀ F
//! m_B [r]× P Ω̇ + (J_w − m_B [r]×[r]×) ω̇ = −m_B g r × e_z − m_B r × c − τ − ω × J_w ω
//!                                          + c_r (Ω − ω) + r × F
//! ```
//!
//! (`m = m_b + m_B`; the floor's normal force and gravity on the ball do no virtual work).
//! The mass matrix is symmetric positive definite; [`BallbotPlant::accelerations`] solves it by
//! Cholesky, [`BallbotPlant::step`] integrates with RK4. Energy
//! `E = ½ m_b |PΩ|² + ½ I_b |Ω|² + ½ m_B |v_B|² + ½ ωᵀ J_w ω + m_B g r_z` is conserved without
//! damping and torques ([`BallbotPlant::energy`]).
//!
//! **Planar models (linearisation about upright).** At `q = 1, u = 0` all velocity terms are
//! quadratic and vanish, `r = l e_z`, `Pᵀ P = R² diag(1, 1, 0)`, `[r]× P = l R diag(1, 1, 0)`,
//! `−[r]×[r]× = l² diag(1, 1, 0)`, and gravity gives `m_B g l (θ_x, θ_y, 0)` for small tilts
//! `θ_x, θ_y` about x and y. The six equations split into three independent pairs: about y
//! (ball angle `φ` with `x = R φ`, tilt `θ_y`, torque `τ_y = −k Ty`), about x (`y = −R φ`,
//! `θ_x`, `τ_x = −k Tx`) and about z (ball spin, body yaw, `τ_z = k Tz`), `k = R/r_w`:
//!
//! ```text
//! (m R² + I_b) φ̈ + m_B l R θ̈        = τ − c_f φ̇ − c_r (φ̇ − θ̇)
//! m_B l R φ̈ + (J + m_B l²) θ̈        = m_B g l θ − τ + c_r (φ̇ − θ̇)
//! ```
//!
//! — the classic ball-and-pendulum of Fankhauser & Gwerder (Rezero, ETH 2010) — whose closed
//! form `A, B` is [`omnikin::control::planar`] ([`BallbotPlant::planar_models`]); the tests
//! compare it with a numerical Jacobian of this 3D model. What the decomposition neglects is
//! listed there.
//!
//! **Not modelled**: the wheels' own inertia (massless wheels), roller and floor slip, Coulomb
//! friction, products of inertia of the body, motor dynamics (torques are applied as
//! commanded, held over the control period), and the body hitting the floor after a fall.
//!
//! Files: [`capability`] (the command limits the balancing robot holds),
//! [`closed_loop`] (the balance controller on this model), [`plan_run`] (a plan
//! through the balancing robot, with noise and pushes: `simulate --plant dynamic`), [`preview`] (a previewed
//! lean a plan can be followed with), [`sil`] (the model as a board for the runtime's balance mode), [`params`] (the parameters and the preset's values), [`model`] (equations, energy,
//! wheels, pushes, measurements), [`state`] (the state), `step` (its RK4 integration).

pub mod capability;
pub mod closed_loop;
pub mod model;
pub mod params;
pub mod plan_run;
pub mod preview;
pub mod sil;
pub mod state;
mod step;

pub use model::BallbotPlant;
pub use params::BallbotDynamics;
pub use state::BallbotState;
