// SPDX-License-Identifier: MIT
#pragma once
/// @file CameraPath.h
/// @brief The camera poses `csgv render` renders one after the other (issue 42): an orbit about
/// the up axis (--orbit N), a camera-path file (--camera-path FILE) so that any peer's path can
/// be replayed, and Volcanite 0.6's default orbital pose (--camera volcanite).
///
/// A camera-path file holds one pose per line, ten numbers: `ex ey ez cx cy cz ux uy uz fovy`
/// (eye, centre and up in world coordinates, the vertical field of view in degrees), separated by
/// blanks or commas; `#` starts a comment, blank lines are skipped. Every pose is checked (finite
/// numbers, the eye away from the centre, an up vector not along the view, 0 < fovy < 180) and
/// an error names the file and line. At most kMaxCameraPoses poses and kMaxCameraPathBytes bytes.
#include "csgv/base/Status.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace csgv {

/// The vertical fields of view (degrees) a pose may take, --fov-y's and a camera path's alike.
constexpr double kMinFovY = 0.01, kMaxFovY = 179;

struct CameraPose {
    std::array<double, 3> eye{}, center{}, up{{0, 0, 1}};
    double fovY = 30; ///< degrees
};

constexpr size_t kMaxCameraPoses = 100000;
constexpr uint64_t kMaxCameraPathBytes = uint64_t(16) << 20;

/// Why a pose cannot be rendered ("" when it can).
std::string poseProblem(const CameraPose& pose);
/// Parses a camera-path text; `name` names it in errors ("FILE line 3: ...").
Result<std::vector<CameraPose>> parseCameraPath(const std::string& text, const std::string& name);
/// Reads and parses a camera-path file (at most kMaxCameraPathBytes).
Result<std::vector<CameraPose>> readCameraPath(const std::string& path);
/// `n` poses: `first`, then its eye turned about its up axis through its centre by 2 pi k / n.
std::vector<CameraPose> orbitPoses(const CameraPose& first, uint32_t n);
/// Volcanite 0.6's default orbital pose for a volume whose world box has this centre and these
/// side lengths: the eye at 1.5 times the largest side from the centre, at elevation 0.5 rad and
/// azimuth 4.0 rad (x = cos(el) cos(az), y = cos(el) sin(az), z = sin(el)), up +z, a vertical
/// field of view of 0.33 pi (59.4 degrees).
CameraPose volcanitePose(const std::array<double, 3>& centre, const std::array<double, 3>& sides);

} // namespace csgv
