// WPILib wpimath side of the peer comparison (bench/peers/run.sh builds and runs it).
//
// Same inputs, same loop shape as bench/rust-harness/src/bin/peer_harness.rs: a 64-entry
// input table built before timing, one call per iteration, every input passed through an
// optimisation barrier and every result consumed by one. One process run = one round: each
// benchmark is warmed up, then timed in batches; the median batch (ns per call) is printed as
// `name<TAB>ns_per_call<TAB>extra` (OMNIKIN_BENCH_MIN=1: the fastest batch instead).
//
// Build: g++ -O2 -std=c++20 wpimath_harness.cpp -I<wpimath>/include -I<wpiutil>/include
//        -L... -lwpimath -lwpiutil
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <frc/geometry/Pose2d.h>
#include <frc/geometry/Rotation2d.h>
#include <frc/geometry/Translation2d.h>
#include <frc/kinematics/ChassisSpeeds.h>
#include <frc/kinematics/MecanumDriveKinematics.h>
#include <frc/kinematics/MecanumDriveOdometry.h>
#include <frc/kinematics/MecanumDriveWheelPositions.h>
#include <frc/kinematics/MecanumDriveWheelSpeeds.h>
#include <frc/kinematics/SwerveDriveKinematics.h>
#include <frc/kinematics/SwerveDriveOdometry.h>
#include <frc/kinematics/SwerveModulePosition.h>
#include <frc/kinematics/SwerveModuleState.h>
#include <frc/trajectory/TrajectoryConfig.h>
#include <frc/trajectory/TrajectoryGenerator.h>
#include <frc/trajectory/constraint/CentripetalAccelerationConstraint.h>
#include <frc/trajectory/constraint/SwerveDriveKinematicsConstraint.h>

namespace {

// Optimisation barriers (the equivalent of Rust's std::hint::black_box).
template <class T>
inline void keep(T const& v) {
  asm volatile("" : : "r,m"(v) : "memory");
}
template <class T>
inline T opaque(T v) {
  asm volatile("" : "+r,m"(v) : : "memory");
  return v;
}

constexpr int K = 64;
constexpr double kMount = 0.20;  // steering-axis radius D of the caster preset, m
constexpr double kWheel = 0.05;  // wheel radius r of the caster preset, m
// Wheel-rim speed limit of omnikin's plan20 (sphere-omni: max_wheel_rate 12 rad/s times its
// wheel_radius 0.07 m), m/s: the module speed limit of the constrained WPILib plan.
constexpr double kPlanWheelRim = 12.0 * 0.07;
constexpr double kPi = 3.14159265358979323846;

struct Inputs {
  double vx[K], vy[K], w[K], heading[K], steer[K][3], dist_step[K][3];
  // Four-wheel tables (mecanum, swerve4): steer angles (rad), per-step wheel travel (m),
  // wheel speeds (m/s). Same formulas as bench/rust-harness/src/bin/peer_harness.rs.
  double steer4[K][4], dist4[K][4], speed4[K][4];
};

Inputs make_inputs() {
  Inputs in{};
  for (int k = 0; k < K; ++k) {
    in.vx[k] = 0.5 * std::sin(0.1 * k + 0.3);
    in.vy[k] = 0.4 * std::cos(0.17 * k);
    in.w[k] = 1.2 * std::sin(0.23 * k + 1.0);
    in.heading[k] = 0.05 * k;
    for (int j = 0; j < 3; ++j) {
      in.steer[k][j] = 0.8 * std::sin(0.13 * k + j);
      in.dist_step[k][j] = 1e-3 * (0.5 + 0.3 * std::sin(0.11 * k + j));
    }
    for (int j = 0; j < 4; ++j) {
      in.steer4[k][j] = 0.8 * std::sin(0.13 * k + j);
      in.dist4[k][j] = 1e-3 * (0.5 + 0.3 * std::sin(0.11 * k + j));
      in.speed4[k][j] = 0.5 * std::sin(0.19 * k + 0.7 * j);
    }
  }
  return in;
}

using Clock = std::chrono::steady_clock;

double g_batch_ms = 20.0;
int g_batches = 15;
// --count NAME N: run exactly N calls of benchmark NAME, untimed (for callgrind), nothing else.
const char* g_count_name = nullptr;
long g_count_n = 0;


// Times `body(i)` (one call per i); returns the median over batches of ns per call.
template <class F>
double measure(F&& body) {
  // Calibrate the batch length to ~g_batch_ms.
  long n = 1;
  for (;;) {
    auto t0 = Clock::now();
    for (long i = 0; i < n; ++i) body(i);
    double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (ms > g_batch_ms / 4 || n > (1L << 40)) {
      n = std::max(1L, (long)(n * g_batch_ms / std::max(ms, 1e-6)));
      break;
    }
    n *= 4;
  }
  std::vector<double> per;
  long base = 0;
  for (int b = 0; b < g_batches; ++b) {
    auto t0 = Clock::now();
    for (long i = 0; i < n; ++i) body(base + i);
    double ns = std::chrono::duration<double, std::nano>(Clock::now() - t0).count();
    base += n;
    per.push_back(ns / n);
  }
  std::sort(per.begin(), per.end());
  // OMNIKIN_BENCH_MIN=1: the fastest batch (a lower bound less disturbed by other load).
  const char* min = std::getenv("OMNIKIN_BENCH_MIN");
  if (min && std::strcmp(min, "1") == 0) return per.front();
  return per[per.size() / 2];
}

// Runs benchmark `name`: timed (prints a line) or, in count mode, N plain calls.
template <class F>
bool run(const char* name, F&& body, double& ns) {
  if (g_count_name) {
    if (std::strcmp(g_count_name, name) == 0)
      for (long i = 0; i < g_count_n; ++i) body(i);
    return false;
  }
  ns = measure(body);
  return true;
}

frc::SwerveDriveKinematics<3> swerve3() {
  // Modules at the caster's steering axes: D (cos a, sin a), a = 0, -120 deg, +120 deg.
  auto at = [](double a) {
    return frc::Translation2d{units::meter_t{kMount * std::cos(a)},
                              units::meter_t{kMount * std::sin(a)}};
  };
  return frc::SwerveDriveKinematics<3>{at(0.0), at(-2.0 * kPi / 3.0), at(2.0 * kPi / 3.0)};
}

constexpr double kR4 = 0.05;  // wheel radius of the mecanum and swerve4 presets, m

// robots/mecanum.toml: FL, FR, RL, RR.
frc::MecanumDriveKinematics mecanum() {
  return frc::MecanumDriveKinematics{
      frc::Translation2d{0.25_m, 0.2_m}, frc::Translation2d{0.25_m, -0.2_m},
      frc::Translation2d{-0.25_m, 0.2_m}, frc::Translation2d{-0.25_m, -0.2_m}};
}

// robots/swerve4.toml: FL, FR, RL, RR at (+-0.3, +-0.3).
frc::SwerveDriveKinematics<4> swerve4() {
  return frc::SwerveDriveKinematics<4>{
      frc::Translation2d{0.3_m, 0.3_m}, frc::Translation2d{0.3_m, -0.3_m},
      frc::Translation2d{-0.3_m, 0.3_m}, frc::Translation2d{-0.3_m, -0.3_m}};
}

frc::ChassisSpeeds chassis(const Inputs& in, int k) {
  return {units::meters_per_second_t{in.vx[k]}, units::meters_per_second_t{in.vy[k]},
          units::radians_per_second_t{in.w[k]}};
}

// --values: the results of the mecanum and swerve4 calls for the same inputs as the Rust
// side's --values, one line per call (`name<TAB>k<TAB>v...`, %.17g), in omnikin's units
// (wheel rates in rad/s = WPILib's m/s / r; directions as cos, sin). bench/peers/agree.py
// compares the two to 1e-9.
void print_values(const Inputs& in) {
  auto row = [](const char* name, int k, std::initializer_list<double> v) {
    std::printf("%s\t%d", name, k);
    for (double x : v) std::printf("\t%.17g", x);
    std::printf("\n");
  };
  {
    auto kin = mecanum();
    for (int k = 0; k < K; ++k) {
      auto w = kin.ToWheelSpeeds(chassis(in, k));
      row("mecanum_inverse", k, {w.frontLeft.value() / kR4, w.frontRight.value() / kR4,
                                  w.rearLeft.value() / kR4, w.rearRight.value() / kR4});
    }
    for (int k = 0; k < K; ++k) {
      frc::MecanumDriveWheelSpeeds w{units::meters_per_second_t{in.speed4[k][0]},
                                     units::meters_per_second_t{in.speed4[k][1]},
                                     units::meters_per_second_t{in.speed4[k][2]},
                                     units::meters_per_second_t{in.speed4[k][3]}};
      auto cs = kin.ToChassisSpeeds(w);
      row("mecanum_forward", k, {cs.vx.value(), cs.vy.value(), cs.omega.value()});
    }
    frc::MecanumDriveOdometry odo{kin, frc::Rotation2d{0_rad}, frc::MecanumDriveWheelPositions{}};
    double d[4] = {0, 0, 0, 0}, yaw = 0.0;
    for (int k = 0; k < 4 * K; ++k) {
      int kk = k & (K - 1);
      for (int j = 0; j < 4; ++j) d[j] += 20.0 * in.dist4[kk][j] * (j % 2 ? 1.0 : -0.5);
      yaw += 1e-3 * in.w[kk] * 20.0;
      auto p = odo.Update(frc::Rotation2d{units::radian_t{yaw}},
                          {units::meter_t{d[0]}, units::meter_t{d[1]}, units::meter_t{d[2]},
                           units::meter_t{d[3]}});
      row("mecanum_odometry", k, {p.X().value(), p.Y().value(), p.Rotation().Cos(),
                                   p.Rotation().Sin()});
    }
  }
  {
    auto kin = swerve4();
    for (int k = 0; k < K; ++k) {
      // Every 16th call a standing robot: the modules keep their previous headings.
      frc::ChassisSpeeds cs = k % 16 == 15 ? frc::ChassisSpeeds{} : chassis(in, k);
      auto st = kin.ToSwerveModuleStates(cs);
      row("swerve4_inverse", k,
          {st[0].speed.value() / kR4, st[1].speed.value() / kR4, st[2].speed.value() / kR4,
           st[3].speed.value() / kR4, st[0].angle.Cos(), st[1].angle.Cos(), st[2].angle.Cos(),
           st[3].angle.Cos(), st[0].angle.Sin(), st[1].angle.Sin(), st[2].angle.Sin(),
           st[3].angle.Sin()});
    }
    for (int k = 0; k < K; ++k) {
      wpi::array<frc::SwerveModuleState, 4> st{wpi::empty_array};
      for (int j = 0; j < 4; ++j)
        st[j] = {units::meters_per_second_t{in.speed4[k][j]},
                 frc::Rotation2d{units::radian_t{in.steer4[k][j]}}};
      auto cs = kin.ToChassisSpeeds(st);
      row("swerve4_forward", k, {cs.vx.value(), cs.vy.value(), cs.omega.value()});
    }
    wpi::array<frc::SwerveModulePosition, 4> pos{wpi::empty_array};
    for (int j = 0; j < 4; ++j) pos[j] = {0_m, frc::Rotation2d{units::radian_t{in.steer4[0][j]}}};
    frc::SwerveDriveOdometry<4> odo{kin, frc::Rotation2d{0_rad}, pos, frc::Pose2d{}};
    double d[4] = {0, 0, 0, 0}, yaw = 0.0;
    for (int k = 0; k < 4 * K; ++k) {
      int kk = k & (K - 1);
      for (int j = 0; j < 4; ++j) d[j] += 20.0 * in.dist4[kk][j];
      yaw += 1e-3 * in.w[kk] * 20.0;
      wpi::array<frc::SwerveModulePosition, 4> p{wpi::empty_array};
      for (int j = 0; j < 4; ++j)
        p[j] = {units::meter_t{d[j]}, frc::Rotation2d{units::radian_t{in.steer4[kk][j]}}};
      auto pose = odo.Update(frc::Rotation2d{units::radian_t{yaw}}, p);
      row("swerve4_odometry", k, {pose.X().value(), pose.Y().value(), pose.Rotation().Cos(),
                                   pose.Rotation().Sin()});
    }
  }
}

// The 20 waypoints of crates/omnikin-plan/benches/plan.rs.
std::vector<frc::Translation2d> waypoints() {
  std::vector<frc::Translation2d> w;
  for (int k = 0; k < 20; ++k) {
    double x = 0.5 * k, y = 0.4 * std::sin(0.9 * k) + 0.1 * std::cos(2.3 * k);
    w.emplace_back(units::meter_t{x}, units::meter_t{y});
  }
  return w;
}

}  // namespace

int main(int argc, char** argv) {
  for (int a = 1; a + 1 < argc; a += 2) {
    if (!std::strcmp(argv[a], "--batch-ms")) g_batch_ms = std::atof(argv[a + 1]);
    if (!std::strcmp(argv[a], "--batches")) g_batches = std::atoi(argv[a + 1]);
    if (!std::strcmp(argv[a], "--count") && a + 2 < argc) {
      g_count_name = argv[a + 1];
      g_count_n = std::atol(argv[a + 2]);
      ++a;
    }
  }
  double ns = 0.0;
  const Inputs in = make_inputs();
  for (int a = 1; a < argc; ++a)
    if (!std::strcmp(argv[a], "--values")) {
      print_values(in);
      return 0;
    }

  // Swerve-3 inverse: chassis speeds -> three module states (speed, angle).
  {
    auto kin = swerve3();
    if (run("swerve3_inverse", [&](long i) {
      int k = (int)(i & (K - 1));
      frc::ChassisSpeeds cs{units::meters_per_second_t{opaque(in.vx[k])},
                            units::meters_per_second_t{opaque(in.vy[k])},
                            units::radians_per_second_t{opaque(in.w[k])}};
      auto st = kin.ToSwerveModuleStates(cs);
      keep(st);
    }, ns))
      std::printf("swerve3_inverse\t%.3f\t-\n", ns);
  }

  // Swerve-3 forward: three (speed, angle) module states -> chassis speeds (least squares
  // through the precomputed pseudo-inverse). The module angles come in as radians, as from
  // encoders, so the Rotation2d constructions (cos/sin) are part of the call, as the Rust
  // side's steer-angle sin_cos are.
  {
    auto kin = swerve3();
    auto states = [&](int k) {
      wpi::array<frc::SwerveModuleState, 3> st{wpi::empty_array};
      for (int j = 0; j < 3; ++j)
        st[j] = {units::meters_per_second_t{opaque(in.dist_step[k][j] * 1e3)},
                 frc::Rotation2d{units::radian_t{opaque(in.steer[k][j])}}};
      return st;
    };
    if (run("swerve3_forward", [&](long i) {
      int k = (int)(i & (K - 1));
      auto st = states(k);
      auto cs = kin.ToChassisSpeeds(st);
      keep(cs);
    }, ns))
      std::printf("swerve3_forward\t%.3f\t-\n", ns);
    // The same turned into the field frame with the gyro angle (radians, as from a gyro):
    // the counterpart of the caster's world-frame body_twist.
    if (run("swerve3_forward_world", [&](long i) {
      int k = (int)(i & (K - 1));
      auto st = states(k);
      auto cs = frc::ChassisSpeeds::FromRobotRelativeSpeeds(
          kin.ToChassisSpeeds(st), frc::Rotation2d{units::radian_t{opaque(in.heading[k])}});
      keep(cs);
    }, ns))
      std::printf("swerve3_forward_world\t%.3f\t-\n", ns);
  }

  // Swerve-3 odometry: SwerveDriveOdometry<3>::Update with gyro angle and module positions.
  // The module angles and the gyro yaw come in as radians, as from encoders, so the
  // Rotation2d constructions (cos/sin) are part of the step, as the Rust side's are.
  {
    auto kin = swerve3();
    wpi::array<frc::SwerveModulePosition, 3> pos{wpi::empty_array};
    for (int j = 0; j < 3; ++j) pos[j] = {0_m, frc::Rotation2d{units::radian_t{in.steer[0][j]}}};
    frc::SwerveDriveOdometry<3> odo{kin, frc::Rotation2d{0_rad}, pos, frc::Pose2d{}};
    double dist[3] = {0, 0, 0};
    double yaw = 0.0;
    if (run("swerve3_odometry", [&](long i) {
      int k = (int)(i & (K - 1));
      for (int j = 0; j < 3; ++j) dist[j] += in.dist_step[k][j];
      yaw += 1e-3 * in.w[k];
      wpi::array<frc::SwerveModulePosition, 3> p{wpi::empty_array};
      for (int j = 0; j < 3; ++j)
        p[j] = {units::meter_t{opaque(dist[j])},
                frc::Rotation2d{units::radian_t{opaque(in.steer[k][j])}}};
      const auto& pose = odo.Update(frc::Rotation2d{units::radian_t{opaque(yaw)}}, p);
      keep(pose);
    }, ns))
      std::printf("swerve3_odometry\t%.3f\t-\n", ns);
  }

  // Mecanum (robots/mecanum.toml): ToWheelSpeeds, ToChassisSpeeds, MecanumDriveOdometry.
  {
    auto kin = mecanum();
    if (run("wpi_mecanum_inverse", [&](long i) {
      int k = (int)(i & (K - 1));
      frc::ChassisSpeeds cs{units::meters_per_second_t{opaque(in.vx[k])},
                            units::meters_per_second_t{opaque(in.vy[k])},
                            units::radians_per_second_t{opaque(in.w[k])}};
      auto w = kin.ToWheelSpeeds(cs);
      keep(w);
    }, ns))
      std::printf("wpi_mecanum_inverse\t%.3f\t-\n", ns);
    if (run("wpi_mecanum_forward", [&](long i) {
      int k = (int)(i & (K - 1));
      frc::MecanumDriveWheelSpeeds w{units::meters_per_second_t{opaque(in.speed4[k][0])},
                                     units::meters_per_second_t{opaque(in.speed4[k][1])},
                                     units::meters_per_second_t{opaque(in.speed4[k][2])},
                                     units::meters_per_second_t{opaque(in.speed4[k][3])}};
      auto cs = kin.ToChassisSpeeds(w);
      keep(cs);
    }, ns))
      std::printf("wpi_mecanum_forward\t%.3f\t-\n", ns);
    frc::MecanumDriveOdometry odo{kin, frc::Rotation2d{0_rad}, frc::MecanumDriveWheelPositions{}};
    double d[4] = {0, 0, 0, 0};
    double yaw = 0.0;
    if (run("wpi_mecanum_odometry", [&](long i) {
      int k = (int)(i & (K - 1));
      for (int j = 0; j < 4; ++j) d[j] += in.dist4[k][j];
      yaw += 1e-3 * in.w[k];
      frc::MecanumDriveWheelPositions p{units::meter_t{opaque(d[0])}, units::meter_t{opaque(d[1])},
                                        units::meter_t{opaque(d[2])}, units::meter_t{opaque(d[3])}};
      const auto& pose = odo.Update(frc::Rotation2d{units::radian_t{opaque(yaw)}}, p);
      keep(pose);
    }, ns))
      std::printf("wpi_mecanum_odometry\t%.3f\t-\n", ns);
  }

  // Swerve4 (robots/swerve4.toml): ToSwerveModuleStates, ToChassisSpeeds (module angles in
  // radians, so the Rotation2d constructions are part of the call, as the Rust side's
  // sin_cos), SwerveDriveOdometry<4>.
  {
    auto kin = swerve4();
    if (run("wpi_swerve4_inverse", [&](long i) {
      int k = (int)(i & (K - 1));
      frc::ChassisSpeeds cs{units::meters_per_second_t{opaque(in.vx[k])},
                            units::meters_per_second_t{opaque(in.vy[k])},
                            units::radians_per_second_t{opaque(in.w[k])}};
      auto st = kin.ToSwerveModuleStates(cs);
      keep(st);
    }, ns))
      std::printf("wpi_swerve4_inverse\t%.3f\t-\n", ns);
    if (run("wpi_swerve4_forward", [&](long i) {
      int k = (int)(i & (K - 1));
      wpi::array<frc::SwerveModuleState, 4> st{wpi::empty_array};
      for (int j = 0; j < 4; ++j)
        st[j] = {units::meters_per_second_t{opaque(in.speed4[k][j])},
                 frc::Rotation2d{units::radian_t{opaque(in.steer4[k][j])}}};
      auto cs = kin.ToChassisSpeeds(st);
      keep(cs);
    }, ns))
      std::printf("wpi_swerve4_forward\t%.3f\t-\n", ns);
    wpi::array<frc::SwerveModulePosition, 4> pos{wpi::empty_array};
    for (int j = 0; j < 4; ++j) pos[j] = {0_m, frc::Rotation2d{units::radian_t{in.steer4[0][j]}}};
    frc::SwerveDriveOdometry<4> odo{kin, frc::Rotation2d{0_rad}, pos, frc::Pose2d{}};
    double d[4] = {0, 0, 0, 0};
    double yaw = 0.0;
    if (run("wpi_swerve4_odometry", [&](long i) {
      int k = (int)(i & (K - 1));
      for (int j = 0; j < 4; ++j) d[j] += in.dist4[k][j];
      yaw += 1e-3 * in.w[k];
      wpi::array<frc::SwerveModulePosition, 4> p{wpi::empty_array};
      for (int j = 0; j < 4; ++j)
        p[j] = {units::meter_t{opaque(d[j])},
                frc::Rotation2d{units::radian_t{opaque(in.steer4[k][j])}}};
      const auto& pose = odo.Update(frc::Rotation2d{units::radian_t{opaque(yaw)}}, p);
      keep(pose);
    }, ns))
      std::printf("wpi_swerve4_odometry\t%.3f\t-\n", ns);
  }

  // 20-waypoint trajectory with max velocity and acceleration (the Rust bench's limits).
  {
    auto w = waypoints();
    auto heading = [](frc::Translation2d a, frc::Translation2d b) {
      return frc::Rotation2d{(b - a).X().value(), (b - a).Y().value()};
    };
    frc::Pose2d start{w.front(), heading(w[0], w[1])};
    frc::Pose2d end{w.back(), heading(w[18], w[19])};
    std::vector<frc::Translation2d> interior(w.begin() + 1, w.end() - 1);
    double saved_batch = g_batch_ms;
    g_batch_ms = std::max(g_batch_ms * 5, 50.0);
    bool timed = run("plan20_wpilib", [&](long) {
      frc::TrajectoryConfig cfg{0.6_mps, 1.0_mps_sq};
      auto traj = frc::TrajectoryGenerator::GenerateTrajectory(opaque(start), interior,
                                                               opaque(end), cfg);
      keep(traj);
    }, ns);
    g_batch_ms = saved_batch;
    if (timed) {
      // What one call produces (outside the timed loop).
      frc::TrajectoryConfig cfg{0.6_mps, 1.0_mps_sq};
      auto traj = frc::TrajectoryGenerator::GenerateTrajectory(start, interior, end, cfg);
      size_t states = traj.States().size();
      double total_time = traj.TotalTime().value(), length = 0.0;
      for (size_t s = 1; s < states; ++s)
        length += traj.States()[s].pose.Translation().Distance(traj.States()[s - 1].pose.Translation()).value();
      std::printf("plan20_wpilib\t%.3f\tstates=%zu duration_s=%.3f length_m=%.3f\n", ns, states,
                  total_time, length);
    }

    // The like-for-like variant: omnikin's planner enforces per-wheel limits, so WPILib gets
    // its per-module speed constraint too, on the caster-like swerve3 above (the robot turns
    // with the tangent, as the constraint assumes: omega = v * curvature), with the wheel-rim
    // speed omnikin's plan allows (sphere-omni: 12 rad/s on 0.07 m wheels = 0.84 m/s), and a
    // centripetal constraint at the path acceleration limit (1 m/s^2).
    // The configuration (and the kinematics' pseudo-inverse in it) is built once, outside
    // the loop, as omnikin's robot model is.
    frc::TrajectoryConfig constrained{0.6_mps, 1.0_mps_sq};
    constrained.AddConstraint(frc::SwerveDriveKinematicsConstraint<3>{
        swerve3(), units::meters_per_second_t{kPlanWheelRim}});
    constrained.AddConstraint(frc::CentripetalAccelerationConstraint{1.0_mps_sq});
    g_batch_ms = std::max(saved_batch * 5, 50.0);
    timed = run("plan20_wpilib_constrained", [&](long) {
      const auto& cfg = constrained;
      auto traj = frc::TrajectoryGenerator::GenerateTrajectory(opaque(start), interior,
                                                               opaque(end), cfg);
      keep(traj);
    }, ns);
    g_batch_ms = saved_batch;
    if (!timed) return 0;
    auto traj2 = frc::TrajectoryGenerator::GenerateTrajectory(start, interior, end, constrained);
    std::printf("plan20_wpilib_constrained\t%.3f\tstates=%zu duration_s=%.3f\n", ns,
                traj2.States().size(), traj2.TotalTime().value());
  }
  return 0;
}
