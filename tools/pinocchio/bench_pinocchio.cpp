// Pinocchio timing harness: the C++ counterpart of centaur-dynamics' `dyn_bench`.
//
// usage: bench_pinocchio URDF [--floating-base] [--pool N] [--min-rounds R]
//                              [--budget-ms MS] [--seed S] [--dump-first]
//
// Prints one JSON object on stdout, median nanoseconds per call:
//   {"fk": .., "jacobians": .., "rnea": .., "crba": .., "aba": .., "centroidal": ..,
//    "nq": .., "nv": ..}
// ("nq"/"nv" are Pinocchio's; extra keys for the side-by-side table.)
//
// Method: a pool of N random states (q, v, a, tau) is drawn once. One "round"
// calls the algorithm once on every state of the pool and yields
// (round time / N); rounds repeat until both --min-rounds and --budget-ms are
// reached, and the median over rounds is reported. One warm-up round is
// discarded. All algorithms share one pinocchio::Data, as a controller would.
//
// --dump-first prints instead the first pool state and Pinocchio's results on
// it (rnea, crba, aba, centroidal map, com), so that a script can verify this
// build against the Python bindings (see bench_side_by_side.py --verify).
//
// Build (bench_side_by_side.py does it for you; it prints the command):
//   g++ -O3 -march=native -DNDEBUG -std=c++17
//       -DEIGEN_MAX_ALIGN_BYTES=16 -DEIGEN_MALLOC_ALREADY_ALIGNED=1 ...
// The model is built by pinocchio::urdf::buildModel, whose parser lives in the
// pip package's libpinocchio_parsers, compiled for baseline x86-64 (SSE2, so
// Eigen objects 16-byte aligned and heap blocks from plain malloc). With
// -march=native on an AVX/AVX-512 machine Eigen would otherwise assume 32/64-byte
// aligned heap blocks and allocate/free them with its own over-aligning
// allocator: the Model the library fills in then crashes (unaligned packet
// loads, or free() of a pointer Eigen never offset). The two macros keep the
// layout and the allocator identical to the library's; vector instructions
// are still AVX/AVX-512 (unaligned loads).
// The algorithms themselves are compiled here, from the headers, with
// -march=native: PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION is deliberately left
// undefined so that the library's precompiled (baseline) instantiations are
// not used.

#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/center-of-mass.hpp>
#include <pinocchio/algorithm/centroidal.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/parsers/urdf.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <random>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
using Eigen::VectorXd;

struct Options {
  std::string urdf;
  bool floating_base = false;
  int pool = 1000;
  int min_rounds = 31;
  double budget_ms = 300.0;
  unsigned seed = 42;
  bool dump_first = false;
};

[[noreturn]] void usage(const char *msg) {
  std::fprintf(stderr,
               "error: %s\nusage: bench_pinocchio URDF [--floating-base] [--pool N] "
               "[--min-rounds R] [--budget-ms MS] [--seed S] [--dump-first]\n",
               msg);
  std::exit(2);
}

Options parse_args(int argc, char **argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char * {
      if (i + 1 >= argc) usage(("missing value after " + a).c_str());
      return argv[++i];
    };
    if (a == "--floating-base") o.floating_base = true;
    else if (a == "--pool") o.pool = std::atoi(next());
    else if (a == "--min-rounds") o.min_rounds = std::atoi(next());
    else if (a == "--budget-ms") o.budget_ms = std::atof(next());
    else if (a == "--seed") o.seed = static_cast<unsigned>(std::atol(next()));
    else if (a == "--dump-first") o.dump_first = true;
    else if (!a.empty() && a[0] == '-') usage(("unknown option " + a).c_str());
    else if (o.urdf.empty()) o.urdf = a;
    else usage("more than one URDF given");
  }
  if (o.urdf.empty()) usage("no URDF given");
  if (o.pool < 1 || o.min_rounds < 1) usage("--pool and --min-rounds must be >= 1");
  return o;
}

// One random configuration, joint by joint:
// free flyer: position in [-1, 1]^3, uniformly random unit quaternion;
// 1-dof joint: uniform within its limits when they are finite and lower < upper,
//   else in [-pi, pi] (urdfdom turns a missing lower/upper into [0, 0]);
// unbounded revolute (URDF "continuous", stored as cos/sin): random angle.
VectorXd random_q(const pinocchio::Model &model, std::mt19937_64 &rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  std::normal_distribution<double> gauss(0.0, 1.0);
  VectorXd q(model.nq);
  for (pinocchio::JointIndex j = 1; j < static_cast<pinocchio::JointIndex>(model.njoints); ++j) {
    const auto &jm = model.joints[j];
    const int iq = jm.idx_q();
    const std::string kind = jm.shortname();
    if (kind == "JointModelFreeFlyer") {
      for (int k = 0; k < 3; ++k) q[iq + k] = unit(rng);
      Eigen::Vector4d quat(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
      q.segment<4>(iq + 3) = quat.normalized();  // x, y, z, w
    } else if (jm.nq() == 2 && jm.nv() == 1) {
      const double t = angle(rng);
      q[iq] = std::cos(t);
      q[iq + 1] = std::sin(t);
    } else if (jm.nq() == 1) {
      const double lo = model.lowerPositionLimit[iq], hi = model.upperPositionLimit[iq];
      if (std::isfinite(lo) && std::isfinite(hi) && lo < hi)
        q[iq] = std::uniform_real_distribution<double>(lo, hi)(rng);
      else
        q[iq] = angle(rng);
    } else {
      std::fprintf(stderr, "error: unsupported joint type %s\n", kind.c_str());
      std::exit(2);
    }
  }
  return q;
}

VectorXd random_vec(int n, std::mt19937_64 &rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  VectorXd x(n);
  for (int i = 0; i < n; ++i) x[i] = gauss(rng);
  return x;
}

struct States {
  std::vector<VectorXd> q, v, a, tau;
};

// Median ns per call of `call(i)` over the pool, see the file header.
// (A template, not std::function, so the call is inlined into the timed loop.)
template <typename F>
double time_median_ns(int pool, const Options &o, F &&call) {
  for (int i = 0; i < pool; ++i) call(i);  // warm-up round
  std::vector<double> per_call;
  const auto start = Clock::now();
  while (true) {
    const auto t0 = Clock::now();
    for (int i = 0; i < pool; ++i) call(i);
    const auto t1 = Clock::now();
    per_call.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() / pool);
    const double elapsed_ms = std::chrono::duration<double, std::milli>(t1 - start).count();
    if (static_cast<int>(per_call.size()) >= o.min_rounds && elapsed_ms >= o.budget_ms) break;
  }
  std::nth_element(per_call.begin(), per_call.begin() + per_call.size() / 2, per_call.end());
  return per_call[per_call.size() / 2];
}

void print_vec(const char *key, const VectorXd &x, bool last = false) {
  std::printf("\"%s\": [", key);
  for (int i = 0; i < x.size(); ++i) std::printf("%s%.17g", i ? ", " : "", x[i]);
  std::printf("]%s\n", last ? "" : ",");
}

void print_mat(const char *key, const Eigen::MatrixXd &m, bool last = false) {
  std::printf("\"%s\": [", key);
  for (int r = 0; r < m.rows(); ++r) {
    std::printf("%s[", r ? ", " : "");
    for (int c = 0; c < m.cols(); ++c) std::printf("%s%.17g", c ? ", " : "", m(r, c));
    std::printf("]");
  }
  std::printf("]%s\n", last ? "" : ",");
}

}  // namespace

int main(int argc, char **argv) {
  const Options o = parse_args(argc, argv);

  pinocchio::Model model;
  try {
    if (o.floating_base)
      pinocchio::urdf::buildModel(o.urdf, pinocchio::JointModelFreeFlyer(), model);
    else
      pinocchio::urdf::buildModel(o.urdf, model);
  } catch (const std::exception &e) {
    std::fprintf(stderr, "error: cannot load %s: %s\n", o.urdf.c_str(), e.what());
    return 1;
  }
  pinocchio::Data data(model);

  // The pool of random states.
  std::mt19937_64 rng(o.seed);
  States s;
  for (int i = 0; i < o.pool; ++i) {
    s.q.push_back(random_q(model, rng));
    s.v.push_back(random_vec(model.nv, rng));
    s.a.push_back(random_vec(model.nv, rng));
    s.tau.push_back(random_vec(model.nv, rng));
  }

  if (o.dump_first) {
    // Results on state 0, for checking this build against the Python bindings.
    const VectorXd &q = s.q[0], &v = s.v[0], &a = s.a[0], &tau = s.tau[0];
    std::printf("{\n");
    print_vec("q", q);
    print_vec("v", v);
    print_vec("a", a);
    print_vec("tau", tau);
    print_vec("rnea", pinocchio::rnea(model, data, q, v, a));
    Eigen::MatrixXd M = pinocchio::crba(model, data, q);
    M.triangularView<Eigen::StrictlyLower>() = M.transpose().triangularView<Eigen::StrictlyLower>();
    print_mat("crba", M);
    print_vec("aba", pinocchio::aba(model, data, q, v, tau));
    print_mat("centroidal", pinocchio::computeCentroidalMap(model, data, q));
    print_vec("com", pinocchio::centerOfMass(model, data, q));
    std::printf("\"eigen\": \"%d.%d.%d\",\n", EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION,
                EIGEN_MINOR_VERSION);
    std::printf("\"simd\": \"%s\",\n", Eigen::SimdInstructionSetsInUse());
    std::printf("\"nq\": %d, \"nv\": %d, \"njoints\": %d\n}\n", model.nq, model.nv,
                model.njoints);
    return 0;
  }

  const int n = o.pool;
  const double fk = time_median_ns(n, o, [&](int i) {
    pinocchio::forwardKinematics(model, data, s.q[i]);
  });
  const double jac = time_median_ns(n, o, [&](int i) {
    pinocchio::computeJointJacobians(model, data, s.q[i]);
  });
  const double rnea = time_median_ns(n, o, [&](int i) {
    pinocchio::rnea(model, data, s.q[i], s.v[i], s.a[i]);
  });
  const double crba = time_median_ns(n, o, [&](int i) {
    pinocchio::crba(model, data, s.q[i]);
  });
  const double aba = time_median_ns(n, o, [&](int i) {
    pinocchio::aba(model, data, s.q[i], s.v[i], s.tau[i]);
  });
  const double centroidal = time_median_ns(n, o, [&](int i) {
    pinocchio::computeCentroidalMap(model, data, s.q[i]);
  });

  std::printf("{\"fk\": %.1f, \"jacobians\": %.1f, \"rnea\": %.1f, \"crba\": %.1f, "
              "\"aba\": %.1f, \"centroidal\": %.1f, \"nq\": %d, \"nv\": %d}\n",
              fk, jac, rnea, crba, aba, centroidal, model.nq, model.nv);
  return 0;
}
