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
#include <frc/kinematics/SwerveDriveKinematics.h>
#include <frc/kinematics/SwerveDriveOdometry.h>
#include <frc/kinematics/SwerveModulePosition.h>
#include <frc/kinematics/SwerveModuleState.h>
#include <frc/trajectory/TrajectoryConfig.h>
#include <frc/trajectory/TrajectoryGenerator.h>

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
constexpr double kPi = 3.14159265358979323846;

struct Inputs {
  double vx[K], vy[K], w[K], heading[K], steer[K][3], dist_step[K][3];
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
    if (!timed) return 0;
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
  return 0;
}
