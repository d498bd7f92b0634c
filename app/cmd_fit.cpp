// `ttp fit SHAPE POINTS`: least-squares fit (geometry/fit.h, true orthogonal
// distances, Ceres for the nonlinear shapes) of a user's point file read
// with inspect's point reader (PLY, PCD, .xyz/.txt/.csv, NIST .ds): the
// parameters with their standard uncertainties and the residuals.
#include <fmt/format.h>

#include <cmath>
#include <iostream>

#include "command.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/fit.h"
#include "ttp/inspect/point_io.h"

namespace ttp::app {
namespace {

constexpr const char* kShapes[] = {"line",   "plane",    "circle2d", "circle3d",
                                   "sphere", "cylinder", "cone"};

struct FitArgs {
  std::string shape;
  std::string points;
  std::string robust = "none";
  double loss_scale_mm = 1e-3;
  std::string units = "mm";
  std::string json;
};

nlohmann::json Vec(const Eigen::VectorXd& v) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v(i));
  return a;
}

// Parameters (named, in mm / unit vectors / deg) and the summary.
nlohmann::json RunFit(const FitArgs& a, const Eigen::Matrix3Xd& p,
                      const fit::FitOptions& fo) {
  nlohmann::json out;
  nlohmann::json& prm = out["parameters"];
  fit::FitSummary summary;
  if (a.shape == "line") {
    const fit::LineFit3D f = fit::FitLine3D(p, fo);
    prm = {{"point_mm", Vec(f.point)}, {"direction", Vec(f.direction)}};
    summary = f.summary;
  } else if (a.shape == "plane") {
    const fit::PlaneFit f = fit::FitPlane(p, fo);
    prm = {{"point_mm", Vec(f.point)}, {"normal", Vec(f.normal)}};
    summary = f.summary;
  } else if (a.shape == "circle2d") {
    const fit::CircleFit2D f = fit::FitCircle2D(p.topRows<2>(), fo);
    prm = {{"centre_mm", Vec(f.centre)},
           {"radius_mm", f.radius_mm},
           {"diameter_mm", 2 * f.radius_mm}};
    summary = f.summary;
  } else if (a.shape == "circle3d") {
    const fit::CircleFit3D f = fit::FitCircle3D(p, fo);
    prm = {{"centre_mm", Vec(f.centre)},
           {"normal", Vec(f.normal)},
           {"radius_mm", f.radius_mm},
           {"diameter_mm", 2 * f.radius_mm}};
    summary = f.summary;
  } else if (a.shape == "sphere") {
    const fit::SphereFit f = fit::FitSphere(p, fo);
    prm = {{"centre_mm", Vec(f.centre)},
           {"radius_mm", f.radius_mm},
           {"diameter_mm", 2 * f.radius_mm}};
    summary = f.summary;
  } else if (a.shape == "cylinder") {
    const fit::CylinderFit f = fit::FitCylinder(p, fo);
    prm = {{"point_mm", Vec(f.point)},
           {"axis", Vec(f.axis)},
           {"radius_mm", f.radius_mm},
           {"diameter_mm", 2 * f.radius_mm}};
    summary = f.summary;
  } else if (a.shape == "cone") {
    const fit::ConeFit f = fit::FitCone(p, fo);
    prm = {{"apex_mm", Vec(f.apex)},
           {"axis", Vec(f.axis)},
           {"half_angle_deg", f.half_angle_rad * 180.0 / M_PI},
           {"point_mm", Vec(f.point)},
           {"radius_at_point_mm", f.radius_at_point_mm}};
    summary = f.summary;
  } else {
    std::string list;
    for (const char* s : kShapes)
      list += std::string(list.empty() ? "" : ", ") + s;
    throw InputError("SHAPE", 0, "shape",
                     "'" + a.shape + "' is not one of " + list);
  }
  // A fit that did not converge, or whose parameters the points do not
  // determine (a cylinder through a plane, a cone of half angle 0), is no
  // result: bad input for this shape, exit 2.
  if (!summary.Usable()) {
    throw InputError(a.points, 0, a.shape,
                     std::string("no ") + a.shape +
                         " fit: " + fit::FitStatusName(summary.status) + ": " +
                         summary.message);
  }
  // A shape through every point exactly (as many residual components as
  // free parameters) leaves no residual to estimate uncertainties from
  // (they are not 0).
  const bool determined = summary.DegreesOfFreedom() > 0;
  nlohmann::json u = nlohmann::json::object();
  for (size_t i = 0; i < summary.parameter_names.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    if (k < summary.covariance.rows())
      u[summary.parameter_names[i]] =
          determined ? nlohmann::json(
                           std::sqrt(std::max(0.0, summary.covariance(k, k))))
                     : nlohmann::json(nullptr);
  }
  out["standard_uncertainty"] = u;
  if (!determined)
    out["uncertainty_note"] = fmt::format(
        "{} points fit a {} of {} free parameters exactly: no residual is "
        "left to estimate the uncertainties",
        summary.points, a.shape, summary.parameter_names.size());
  out["residuals"] = {{"rms_mm", summary.rms_mm},
                      {"max_abs_mm", summary.max_abs_mm}};
  out["points"] = summary.points;
  out["converged"] = summary.converged;
  out["status"] = fit::FitStatusName(summary.status);
  out["termination"] = summary.termination;
  out["iterations"] = summary.iterations;
  if (!summary.message.empty()) out["message"] = summary.message;
  return out;
}

std::string Text(const nlohmann::json& doc) {
  std::string s = fmt::format(
      "{} fit of {} ({} points, {} loss)\n", doc["shape"].get<std::string>(),
      doc["source"].get<std::string>(), doc["points"].get<int>(),
      doc["robust"].get<std::string>());
  for (const auto& [k, v] : doc["parameters"].items()) {
    if (v.is_array()) {
      std::string vals;
      for (const auto& x : v) vals += fmt::format(" {:.9f}", x.get<double>());
      s += fmt::format("  {:<20}{}\n", k, vals);
    } else {
      s += fmt::format("  {:<20} {:.9f}\n", k, v.get<double>());
    }
  }
  s += "standard uncertainties (k = 1):\n";
  for (const auto& [k, v] : doc["standard_uncertainty"].items())
    s += v.is_null() ? fmt::format("  {:<20} not determined\n", k)
                     : fmt::format("  {:<20} {:.3g}\n", k, v.get<double>());
  if (doc.contains("uncertainty_note"))
    s += "  (" + doc["uncertainty_note"].get<std::string>() + ")\n";
  s += fmt::format("residuals: rms {:.6g} mm, max |r| {:.6g} mm{}\n",
                   doc["residuals"]["rms_mm"].get<double>(),
                   doc["residuals"]["max_abs_mm"].get<double>(),
                   doc["converged"].get<bool>() ? "" : " (NOT CONVERGED)");
  return s;
}

void RegisterFit(CLI::App& root, GlobalOptions& global) {
  auto a = std::make_shared<FitArgs>();
  auto* cmd = root.add_subcommand(
      "fit",
      "least-squares fit of a shape to a point file: parameters, standard "
      "uncertainties, residuals");
  cmd->add_option("shape", a->shape,
                  "line, plane, circle2d (from x, y), circle3d, sphere, "
                  "cylinder or cone")
      ->required();
  cmd->add_option("points", a->points,
                  "point file: .xyz/.txt/.csv (x y z per line; a first line "
                  "with the count is allowed, as in NIST .ds), PLY, PCD")
      ->required();
  cmd->add_option("--robust", a->robust, "loss: none (default), huber, cauchy");
  cmd->add_option("--loss-scale-mm", a->loss_scale_mm,
                  "residual scale of the robust loss (mm, default 0.001)");
  cmd->add_option("--units", a->units,
                  "units of the file: mm (default), m, in");
  cmd->add_option("--json", a->json, "write the result as JSON");
  cmd->callback([&global, a] {
    fit::FitOptions fo;
    if (a->robust == "huber")
      fo.loss = fit::FitOptions::Loss::kHuber;
    else if (a->robust == "cauchy")
      fo.loss = fit::FitOptions::Loss::kCauchy;
    else if (a->robust != "none")
      throw InputError("--robust", 0, "robust",
                       "'" + a->robust + "' is not none, huber or cauchy");
    fo.loss_scale_mm = a->loss_scale_mm;
    if (!std::isfinite(a->loss_scale_mm) || a->loss_scale_mm <= 0)
      throw InputError("--loss-scale-mm", 0, "loss_scale_mm",
                       "must be a positive number");
    fo.Validate();
    bool known = false;
    for (const char* s : kShapes) known |= a->shape == s;
    if (!known) RunFit(*a, Eigen::Matrix3Xd(3, 0), fo);  // throws the list
    inspect::ReadOptions ro;
    ro.units = inspect::ParseLengthUnit(a->units);
    ro.units_given = true;
    const inspect::PointCloud cloud = inspect::ReadPointCloud(a->points, ro);
    nlohmann::json doc;
    try {
      doc = RunFit(*a, cloud.xyz_mm, fo);
    } catch (const InputError& e) {
      if (e.source() != "fit") throw;
      // The fit's own checks (too few points, collinear): name the file.
      throw InputError(a->points, 0, a->shape, e.problem());
    }
    // Points that do not determine the shape (a cone on 4 points, a
    // cylinder on a plane) give parameters that are not numbers, or no
    // uncertainty: bad input, not a result.
    const auto finite = [](const nlohmann::json& v) {
      if (v.is_array()) {
        for (const auto& x : v)
          if (!x.is_number() || !std::isfinite(x.get<double>())) return false;
        return true;
      }
      return v.is_number() && std::isfinite(v.get<double>());
    };
    for (const auto& [k, v] : doc["parameters"].items())
      if (!finite(v))
        throw InputError(a->points, 0, a->shape,
                         "the points do not determine a " + a->shape + " (" +
                             k + " is not a finite number)");
    if (doc["standard_uncertainty"].empty())
      throw InputError(a->points, 0, a->shape,
                       "the points do not determine a " + a->shape +
                           " (the fit is rank deficient: no covariance)");
    for (const auto& [k, v] : doc["standard_uncertainty"].items())
      if (!v.is_null() && !finite(v))  // null: an exact fit (said so)
        throw InputError(a->points, 0, a->shape,
                         "the points do not determine a " + a->shape + " (" +
                             k + " has no finite uncertainty)");
    doc["shape"] = a->shape;
    doc["source"] = a->points;
    doc["robust"] = a->robust;
    if (a->robust != "none") doc["loss_scale_mm"] = a->loss_scale_mm;
    doc["units"] = "mm; unit vectors; angles in deg";
    if (!global.quiet) TextOut(a->json) << Text(doc);
    if (!a->json.empty()) WriteJson(a->json, doc);
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(42, RegisterFit);
}  // namespace ttp::app
