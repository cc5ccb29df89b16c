#pragma once
// A calibration press: one probe pushed quasi-statically along the inward
// normal at a surface point, the normal force read after settling at each
// depth (palpa-palpate --indent, and the tests that check the tissue law
// against Hertz contact).

#include "haptics/session.h"

#include <vector>

namespace palpa::haptics {

struct IndentOptions {
  double approach_speed = 0.01;  ///< m/s, between depths (quasi-static: slow against the models)
  double settle = 0.5;           ///< s held at each depth before the force is read
  double start_gap = 0.002;      ///< m above the surface where the press starts
};

struct IndentSample {
  double depth = 0;        ///< m below the undeformed surface along the inward normal
  double force = 0;        ///< N, normal reaction after settling
  Vec3 surface_point = Vec3::Zero();  ///< the virtual vertex on the undeformed surface, organ frame, m
  bool in_contact = false;
};

/// The surface point the press uses: the mesh vertex nearest `near` (m,
/// organ frame) and its outward normal.
struct IndentSite {
  Index vertex = kNoIndex;
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  double thickness = 0;  ///< m, along the inward normal to the opposite side (mesh::inward_thickness)
};
IndentSite indent_site(const SessionModel& model, const Vec3& near);

/// Presses one probe at `site` to each of `depths` (m, increasing) in turn
/// on a fresh session of `model` with `materials` (the model's tissue map,
/// when it has one, replaces them), running the session at its tick rate.
/// Pulse and breathing act as in any session (the press follows the
/// breathing organ). Throws std::invalid_argument for a depth that is not
/// finite and non-negative.
std::vector<IndentSample> indent(std::shared_ptr<const SessionModel> model, const deform::Material& materials,
                                 const IndentSite& site, const std::vector<double>& depths,
                                 const IndentOptions& options = {});

}  // namespace palpa::haptics
