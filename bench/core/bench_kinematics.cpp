// Kinematics and trajectory benchmarks, with orocos-kdl solving the same targets in the same
// binary as the peer. Prints Google Benchmark's table, then a summary table with the ratios,
// KDL's convergence rate and the worst errors.
//
//   build/release/bin/bench_kinematics [--benchmark_min_time=0.2]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

#ifdef SCARATWIN_HAVE_KDL
#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainiksolverpos_lma.hpp>
#include <kdl/chainiksolverpos_nr_jl.hpp>
#include <kdl/chainiksolvervel_pinv.hpp>
#endif

namespace {

using namespace scaratwin;

constexpr int kTargets = 10000;

struct Fixture {
  RobotModel model = paper_robot();
  std::vector<JointVector> joints;
  std::vector<ToolPose> poses;
  Fixture() {
    std::mt19937_64 rng(12345);
    for (int i = 0; i < kTargets; ++i) {
      JointVector q;
      for (int j = 0; j < kNumJoints; ++j) {
        std::uniform_real_distribution<double> d(model.limits[j].min, model.limits[j].max);
        q[j] = d(rng);
      }
      joints.push_back(q);
      poses.push_back(forward(model, q));
    }
  }
};

const Fixture& fx() {
  static const Fixture f;
  return f;
}

void BM_Fk(benchmark::State& state) {
  const Fixture& f = fx();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(forward(f.model, f.joints[i]));
    if (++i == f.joints.size()) i = 0;
  }
}
BENCHMARK(BM_Fk);

void BM_Ik(benchmark::State& state) {
  const Fixture& f = fx();
  size_t i = 0;
  for (auto _ : state) {
    auto r = inverse(f.model, f.poses[i], f.model.home);
    benchmark::DoNotOptimize(r);
    if (++i == f.poses.size()) i = 0;
  }
}
BENCHMARK(BM_Ik);

void BM_Quintic60x4(benchmark::State& state) {
  const Fixture& f = fx();
  size_t i = 0;
  for (auto _ : state) {
    auto t = quintic(f.joints[i], f.joints[i + 1], 6.0, 60);
    benchmark::DoNotOptimize(t.samples.data());
    if (++i == f.joints.size() - 1) i = 0;
  }
}
BENCHMARK(BM_Quintic60x4);

// The per-call figure: the allocation-free form into a buffer the caller keeps.
void BM_QuinticInto60x4(benchmark::State& state) {
  const Fixture& f = fx();
  std::vector<JointSample> buf(60);
  size_t i = 0;
  for (auto _ : state) {
    quintic_into(f.joints[i], f.joints[i + 1], 6.0, buf);
    benchmark::DoNotOptimize(buf.data());
    benchmark::ClobberMemory();
    if (++i == f.joints.size() - 1) i = 0;
  }
}
BENCHMARK(BM_QuinticInto60x4);

#ifdef SCARATWIN_HAVE_KDL
// The chain that reproduces the paper's DH (standard DH, Frame::DH).
KDL::Chain kdl_chain(const RobotModel& m) {
  KDL::Chain c;
  c.addSegment(
      KDL::Segment(KDL::Joint(KDL::Joint::TransZ),
                   KDL::Frame::DH(m.dh[0].a_m, m.dh[0].alpha_rad, m.dh[0].d_m, m.dh[0].theta_rad)));
  for (int i = 1; i < kNumJoints; ++i) {
    c.addSegment(KDL::Segment(
        KDL::Joint(KDL::Joint::RotZ),
        KDL::Frame::DH(m.dh[i].a_m, m.dh[i].alpha_rad, m.dh[i].d_m, m.dh[i].theta_rad)));
  }
  return c;
}

KDL::Frame kdl_target(const ToolPose& p) {
  return KDL::Frame(KDL::Rotation::RotZ(p.yaw_rad), KDL::Vector(p.x_m, p.y_m, p.z_m));
}

KDL::JntArray kdl_joints(const JointVector& q) {
  KDL::JntArray a(kNumJoints);
  for (int j = 0; j < kNumJoints; ++j) a(j) = q[j];
  return a;
}

struct KdlSolvers {
  KDL::Chain chain = kdl_chain(fx().model);
  KDL::ChainFkSolverPos_recursive fk{chain};
  Eigen::Matrix<double, 6, 1> weights =
      (Eigen::Matrix<double, 6, 1>() << 1, 1, 1, 0, 0, 1).finished();
  KDL::ChainIkSolverPos_LMA lma{chain, weights};
  KDL::ChainIkSolverVel_pinv vel{chain};
  KDL::JntArray qmin{kdl_joints({fx().model.limits[0].min, fx().model.limits[1].min,
                                 fx().model.limits[2].min, fx().model.limits[3].min})};
  KDL::JntArray qmax{kdl_joints({fx().model.limits[0].max, fx().model.limits[1].max,
                                 fx().model.limits[2].max, fx().model.limits[3].max})};
  KDL::ChainIkSolverPos_NR_JL nrjl{chain, qmin, qmax, fk, vel, 100, 1e-12};
};

KdlSolvers& kdl() {
  static KdlSolvers k;
  return k;
}

void BM_KdlFk(benchmark::State& state) {
  const Fixture& f = fx();
  KDL::Frame out;
  std::vector<KDL::JntArray> q;
  for (const auto& j : f.joints) q.push_back(kdl_joints(j));
  size_t i = 0;
  for (auto _ : state) {
    kdl().fk.JntToCart(q[i], out);
    benchmark::DoNotOptimize(out);
    if (++i == q.size()) i = 0;
  }
}
BENCHMARK(BM_KdlFk);

void BM_KdlIkLma(benchmark::State& state) {
  const Fixture& f = fx();
  const KDL::JntArray seed = kdl_joints(f.model.home);
  KDL::JntArray out(kNumJoints);
  size_t i = 0;
  for (auto _ : state) {
    kdl().lma.CartToJnt(seed, kdl_target(f.poses[i]), out);
    benchmark::DoNotOptimize(out);
    if (++i == f.poses.size()) i = 0;
  }
}
BENCHMARK(BM_KdlIkLma);

void BM_KdlIkNrJl(benchmark::State& state) {
  const Fixture& f = fx();
  const KDL::JntArray seed = kdl_joints(f.model.home);
  KDL::JntArray out(kNumJoints);
  size_t i = 0;
  for (auto _ : state) {
    kdl().nrjl.CartToJnt(seed, kdl_target(f.poses[i]), out);
    benchmark::DoNotOptimize(out);
    if (++i == f.poses.size()) i = 0;
  }
}
BENCHMARK(BM_KdlIkNrJl);
#endif

// Median time per call (ns) of `fn` over all targets, 5 repetitions.
template <typename Fn>
double time_per_call_ns(int reps, Fn fn) {
  std::vector<double> per;
  for (int r = 0; r < reps; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < kTargets; ++i) fn(i);
    const auto t1 = std::chrono::steady_clock::now();
    per.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() / kTargets);
  }
  std::sort(per.begin(), per.end());
  return per[per.size() / 2];
}

struct Accuracy {
  int solved = 0;
  double worst_m = 0.0;
  double worst_rad = 0.0;
};

void record(Accuracy& a, const ToolPose& got, const ToolPose& want) {
  ++a.solved;
  a.worst_m = std::max({a.worst_m, std::abs(got.x_m - want.x_m), std::abs(got.y_m - want.y_m),
                        std::abs(got.z_m - want.z_m)});
  a.worst_rad = std::max(a.worst_rad, std::abs(wrap_angle(got.yaw_rad - want.yaw_rad)));
}

void print_summary() {
  const Fixture& f = fx();
  volatile double sink = 0.0;
  Accuracy ours;
  for (int i = 0; i < kTargets; ++i) {
    auto q = inverse(f.model, f.poses[i], f.model.home);
    if (q) record(ours, forward(f.model, *q), f.poses[i]);
  }
  const double ik_ns = time_per_call_ns(5, [&](int i) {
    auto q = inverse(f.model, f.poses[i], f.model.home);
    sink = sink + (q ? (*q)[1] : 0.0);
  });
  const double fk_ns =
      time_per_call_ns(5, [&](int i) { sink = sink + forward(f.model, f.joints[i]).x_m; });
  const double quintic_alloc_ns = time_per_call_ns(5, [&](int i) {
    auto t = quintic(f.joints[i], f.joints[(i + 1) % kTargets], 6.0, 60);
    sink = sink + t.samples[30].q[1];
  });
  std::vector<JointSample> buf(60);
  const double quintic_ns = time_per_call_ns(5, [&](int i) {
    quintic_into(f.joints[i], f.joints[(i + 1) % kTargets], 6.0, buf);
    sink = sink + buf[30].q[1];
  });
  fmt::print("\n{:<34} {:>12} {:>10} {:>12} {:>14} {:>12}\n", "solver (10,000 random targets)",
             "ns/call", "solved", "worst m", "worst yaw rad", "vs ours");
  const auto row = [&](const char* name, double ns, const Accuracy& a, double ratio) {
    fmt::print("{:<34} {:>12.1f} {:>9.1f}% {:>12.2e} {:>14.2e} {:>11.1f}x\n", name, ns,
               100.0 * a.solved / kTargets, a.worst_m, a.worst_rad, ratio);
  };
  row("scaratwin closed-form IK", ik_ns, ours, 1.0);
#ifdef SCARATWIN_HAVE_KDL
  KdlSolvers& k = kdl();
  const KDL::JntArray seed = kdl_joints(f.model.home);
  KDL::JntArray out(kNumJoints);
  KDL::Frame fr;
  Accuracy lma, nrjl;
  for (int i = 0; i < kTargets; ++i) {
    if (k.lma.CartToJnt(seed, kdl_target(f.poses[i]), out) >= 0) {
      k.fk.JntToCart(out, fr);
      double r, p, y;
      fr.M.GetRPY(r, p, y);
      record(lma, ToolPose{fr.p.x(), fr.p.y(), fr.p.z(), y}, f.poses[i]);
    }
    if (k.nrjl.CartToJnt(seed, kdl_target(f.poses[i]), out) >= 0) {
      k.fk.JntToCart(out, fr);
      double r, p, y;
      fr.M.GetRPY(r, p, y);
      record(nrjl, ToolPose{fr.p.x(), fr.p.y(), fr.p.z(), y}, f.poses[i]);
    }
  }
  const double lma_ns = time_per_call_ns(3, [&](int i) {
    k.lma.CartToJnt(seed, kdl_target(f.poses[i]), out);
    sink = sink + out(1);
  });
  const double nrjl_ns = time_per_call_ns(3, [&](int i) {
    k.nrjl.CartToJnt(seed, kdl_target(f.poses[i]), out);
    sink = sink + out(1);
  });
  std::vector<KDL::JntArray> qs;
  for (const auto& j : f.joints) qs.push_back(kdl_joints(j));
  const double kfk_ns = time_per_call_ns(5, [&](int i) {
    k.fk.JntToCart(qs[i], fr);
    sink = sink + fr.p.x();
  });
  row("KDL ChainIkSolverPos_LMA (home)", lma_ns, lma, lma_ns / ik_ns);
  row("KDL ChainIkSolverPos_NR_JL (home)", nrjl_ns, nrjl, nrjl_ns / ik_ns);
  fmt::print("\n{:<34} {:>12}\n", "other", "ns/call");
  fmt::print("{:<34} {:>12.1f}   (KDL FK {:.1f} ns, {:.1f}x)\n", "scaratwin FK", fk_ns, kfk_ns,
             kfk_ns / fk_ns);
#else
  fmt::print("(orocos-kdl not found: no peer)\n");
  fmt::print("{:<34} {:>12.1f}\n", "scaratwin FK", fk_ns);
#endif
  fmt::print("{:<34} {:>12.1f}   (quintic_into, a kept buffer)\n", "scaratwin quintic 60 x 4",
             quintic_ns);
  fmt::print("{:<34} {:>12.1f}   (quintic(), allocates its trajectory)\n",
             "scaratwin quintic 60 x 4 alloc", quintic_alloc_ns);
  fmt::print(
      "targets: IK <= 60 ns and >= 300x KDL LMA at <= 1e-12 m, 100% solved; FK <= 25 ns; "
      "quintic 60x4 <= 300 ns\n");
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  print_summary();
  return 0;
}
