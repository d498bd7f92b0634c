// Thermal plants for the TALC tests, written from the physics with their
// own parameterisation (not the replay's regressors):
// - LaggedLinearSeries: outputs exactly linear in first-order lags of the
//   speed (and its square) and in a temperature change; the lags are
//   integrated with RK4 in 1 s substeps of the held input, not with the
//   replay's closed-form discretisation.
// - TwoNodePlant: a spindle node heated by friction (a n + b n^2) and
//   coupled to a structure node and to a drifting ambient; displacement
//   linear in both node temperatures plus fixed-seed noise. Its response to
//   speed is second order, so the replay's model is only an approximation.
#pragma once

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "ttp/models/time_series.h"

namespace ttp::talc::test {

// Speed blocks of random level (0..5000/min) and duration (1..4 h).
inline std::vector<double> SpeedBlocks(const std::vector<double>& t_s,
                                       unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> level(0, 5000), dur(3600, 4 * 3600);
  std::vector<double> n(t_s.size());
  double block_end = -1, value = 0;
  for (size_t i = 0; i < t_s.size(); ++i) {
    if (t_s[i] >= block_end) {
      value = std::round(level(rng) / 250) * 250;
      block_end = t_s[i] + dur(rng);
    }
    n[i] = i == 0 ? 0.0 : value;
  }
  return n;
}

// Sample times every step_s, with a jitter of up to +-jitter_s (sorted).
inline std::vector<double> Times(double end_s, double step_s, double jitter_s,
                                 unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> j(-jitter_s, jitter_s);
  std::vector<double> t;
  for (double v = 0; v <= end_s + 1e-9; v += step_s)
    t.push_back(v == 0 ? 0 : v + j(rng));
  return t;
}

// x' = (u - x)/tau with u held at its sample value until the next sample.
inline std::vector<double> Rk4Lag(const std::vector<double>& t,
                                  const std::vector<double>& u, double tau) {
  std::vector<double> x(u.size());
  x[0] = u[0];
  for (size_t k = 1; k < u.size(); ++k) {
    double v = x[k - 1];
    const double span = t[k] - t[k - 1];
    const int steps = std::max(1, int(std::ceil(span)));
    const double h = span / steps;
    auto f = [&](double xv) { return (u[k - 1] - xv) / tau; };
    for (int s = 0; s < steps; ++s) {
      const double k1 = f(v), k2 = f(v + h / 2 * k1), k3 = f(v + h / 2 * k2),
                   k4 = f(v + h * k3);
      v += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    x[k] = v;
  }
  return x;
}

inline models::TimeSeries MakeSeries(
    const std::vector<double>& t, const std::vector<std::string>& in_names,
    const std::vector<std::vector<double>>& in,
    const std::vector<std::string>& out_names,
    const std::vector<std::vector<double>>& out) {
  models::TimeSeries s;
  s.source = "synthetic";
  s.t_s = t;
  s.input_names = in_names;
  s.output_names = out_names;
  s.inputs.resize(Eigen::Index(t.size()), Eigen::Index(in.size()));
  s.outputs_um.resize(Eigen::Index(t.size()), Eigen::Index(out.size()));
  for (size_t i = 0; i < t.size(); ++i) {
    for (size_t c = 0; c < in.size(); ++c)
      s.inputs(Eigen::Index(i), Eigen::Index(c)) = in[c][i];
    for (size_t c = 0; c < out.size(); ++c)
      s.outputs_um(Eigen::Index(i), Eigen::Index(c)) = out[c][i];
  }
  return s;
}

// Outputs: d_a = 3 lag(n,1800) - 1.5 lag(n^2,1800) + 2 lag(n,7200)
//               + 0.5 lag(n^2,7200) + 4 dT_env + 1 (n in 1000/min);
//          d_b = -6 lag(n,7200) + 2.5 dT_env.
inline models::TimeSeries LaggedLinearSeries(double end_s, double step_s,
                                             double jitter_s, unsigned seed) {
  const auto t = Times(end_s, step_s, jitter_s, seed);
  const auto n = SpeedBlocks(t, seed + 1);
  std::vector<double> u(n.size()), u2(n.size()), env(n.size());
  for (size_t i = 0; i < n.size(); ++i) {
    u[i] = n[i] / 1000;
    u2[i] = u[i] * u[i];
    env[i] =
        20 + 0.8 * std::sin(t[i] / 20000.0) + 0.3 * std::sin(t[i] / 3100.0);
  }
  const auto a1 = Rk4Lag(t, u, 1800), b1 = Rk4Lag(t, u2, 1800),
             a2 = Rk4Lag(t, u, 7200), b2 = Rk4Lag(t, u2, 7200);
  std::vector<double> da(n.size()), db(n.size());
  for (size_t i = 0; i < n.size(); ++i) {
    const double dT = env[i] - env[0];
    da[i] = 3 * a1[i] - 1.5 * b1[i] + 2 * a2[i] + 0.5 * b2[i] + 4 * dT + 1;
    db[i] = -6 * a2[i] + 2.5 * dT;
  }
  return MakeSeries(t, {"n_spindle", "T_env"}, {n, env}, {"d_a", "d_b"},
                    {da, db});
}

struct TwoNodePlant {
  double c_spindle_J_K = 4.0e5, c_structure_J_K = 4.0e6;
  double g_sp_st_W_K = 60, g_sp_air_W_K = 25, g_st_air_W_K = 90;
  double a_W_per_rpm = 0.02, b_W_per_rpm2 = 1.2e-5;
  double alpha_um_K = 6.0, beta_um_K = -9.0;  // output d_z
  double gamma_um_K = 2.0, delta_um_K = 4.0;  // output d_y
  double noise_um = 0.3, sensor_noise_K = 0.02;
  unsigned seed = 11;

  models::TimeSeries Make(double end_s, double step_s) const {
    const auto t = Times(end_s, step_s, 0.0, seed);
    const auto n = SpeedBlocks(t, seed + 1);
    std::mt19937 rng(seed + 2);
    std::normal_distribution<double> e(0, noise_um), es(0, sensor_noise_K);
    std::vector<double> ts(t.size()), tst(t.size()), ta(t.size()), dz(t.size()),
        dy(t.size());
    auto ambient = [](double tt) {
      return 20 + 1.2 * std::sin(2 * M_PI * tt / 86400.0) +
             0.2 * std::sin(2 * M_PI * tt / 7000.0);
    };
    double xs = ambient(0), xt = ambient(0);
    const double s0 = xs, st0 = xt;
    for (size_t i = 0; i < t.size(); ++i) {
      if (i > 0) {
        const double h = 1.0;
        const double p =
            a_W_per_rpm * n[i - 1] + b_W_per_rpm2 * n[i - 1] * n[i - 1];
        for (double tt = t[i - 1]; tt < t[i] - 1e-9; tt += h) {
          const double dt = std::min(h, t[i] - tt);
          const double amb = ambient(tt);
          const double fs =
              (p - g_sp_st_W_K * (xs - xt) - g_sp_air_W_K * (xs - amb)) /
              c_spindle_J_K;
          const double ft =
              (g_sp_st_W_K * (xs - xt) - g_st_air_W_K * (xt - amb)) /
              c_structure_J_K;
          xs += dt * fs;
          xt += dt * ft;
        }
      }
      ts[i] = xs + es(rng);
      tst[i] = xt + es(rng);
      ta[i] = ambient(t[i]) + es(rng);
      dz[i] = alpha_um_K * (xs - s0) + beta_um_K * (xt - st0) + e(rng);
      dy[i] = gamma_um_K * (xs - s0) + delta_um_K * (xt - st0) + e(rng);
    }
    return MakeSeries(t, {"n_spindle", "T_spindle", "T_structure", "T_air"},
                      {n, ts, tst, ta}, {"d_z", "d_y"}, {dz, dy});
  }
};

}  // namespace ttp::talc::test
