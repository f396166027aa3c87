// SPDX-License-Identifier: MIT
#include "CameraPath.h"

#include <sstream>

#include "csgv/base/FileUtil.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace csgv {

namespace {

using Vec3 = std::array<double, 3>;

double norm(const Vec3& v) { return std::hypot(v[0], v[1], v[2]); }

Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

/// The numbers of one line (blanks or commas between them); false with the word that is not one.
bool numbersOf(const std::string& line, std::vector<double>& out, std::string& bad) {
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == ',' || line[i] == '\r')) ++i;
        if (i >= line.size()) break;
        size_t j = i;
        while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != ',' && line[j] != '\r') ++j;
        const std::string word = line.substr(i, j - i);
        char* end = nullptr;
        const double v = std::strtod(word.c_str(), &end);
        if (!end || *end != '\0' || !std::isfinite(v)) {
            bad = word;
            return false;
        }
        out.push_back(v);
        i = j;
    }
    return true;
}

std::string formatDegrees(double d) {
    std::ostringstream o;
    o << d;
    return o.str();
}

} // namespace

std::string poseProblem(const CameraPose& p) {
    for (const Vec3* v : {&p.eye, &p.center, &p.up})
        for (double x : *v)
            if (!std::isfinite(x)) return "a coordinate is not a finite number";
    if (!(p.fovY >= kMinFovY && p.fovY <= kMaxFovY))
        return "the field of view must lie between " + formatDegrees(kMinFovY) + " and " + formatDegrees(kMaxFovY) +
               " degrees, as --fov-y's";
    const Vec3 view{p.center[0] - p.eye[0], p.center[1] - p.eye[1], p.center[2] - p.eye[2]};
    const double d = norm(view), u = norm(p.up); // std::hypot: no overflow or underflow of the squares
    if (!std::isfinite(d)) return "the eye is too far from the centre";
    if (!(d > 0)) return "the eye is at the centre";
    if (!(u > 0)) return "the up vector is zero";
    const Vec3 v{view[0] / d, view[1] / d, view[2] / d}, w{p.up[0] / u, p.up[1] / u, p.up[2] / u};
    if (norm(cross(v, w)) <= 1e-9) return "the up vector lies along the view direction";
    return std::string();
}

Result<std::vector<CameraPose>> parseCameraPath(const std::string& text, const std::string& name) {
    std::vector<CameraPose> poses;
    size_t lineNo = 0, from = 0;
    while (from <= text.size()) {
        size_t to = text.find('\n', from);
        if (to == std::string::npos) to = text.size();
        std::string line = text.substr(from, to - from);
        from = to + 1;
        ++lineNo;
        if (const size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
        std::vector<double> v;
        std::string bad;
        const std::string where = name + " line " + std::to_string(lineNo) + ": ";
        if (!numbersOf(line, v, bad)) return Status::error(where + "'" + bad.substr(0, 40) + "' is not a finite number");
        if (v.empty()) continue;
        if (v.size() != 10)
            return Status::error(where + std::to_string(v.size()) +
                                 " numbers; a pose is ten: ex ey ez cx cy cz ux uy uz fovy (degrees)");
        if (poses.size() == kMaxCameraPoses)
            return Status::error(name + ": more than " + std::to_string(kMaxCameraPoses) + " poses");
        CameraPose p;
        p.eye = {v[0], v[1], v[2]};
        p.center = {v[3], v[4], v[5]};
        p.up = {v[6], v[7], v[8]};
        p.fovY = v[9];
        if (const std::string why = poseProblem(p); !why.empty()) return Status::error(where + why);
        poses.push_back(p);
        if (to == text.size()) break;
    }
    if (poses.empty()) return Status::error(name + ": no pose (one a line: ex ey ez cx cy cz ux uy uz fovy)");
    return poses;
}

Result<std::vector<CameraPose>> readCameraPath(const std::string& path) {
    Result<std::vector<uint8_t>> bytes = readFile(path, kMaxCameraPathBytes);
    if (!bytes) return bytes.status();
    return parseCameraPath(std::string(bytes->begin(), bytes->end()), path);
}

std::vector<CameraPose> orbitPoses(const CameraPose& first, uint32_t n) {
    std::vector<CameraPose> out;
    Vec3 u = first.up;
    const double ul = norm(u);
    for (double& x : u) x /= ul;
    const Vec3 p{first.eye[0] - first.center[0], first.eye[1] - first.center[1], first.eye[2] - first.center[2]};
    const double dot = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
    const Vec3 cr = cross(u, p);
    for (uint32_t k = 0; k < n; ++k) {
        const double ang = 2 * 3.14159265358979323846 * k / n;
        CameraPose q = first;
        for (int i = 0; i < 3; ++i)
            q.eye[size_t(i)] = first.center[size_t(i)] + p[size_t(i)] * std::cos(ang) + cr[size_t(i)] * std::sin(ang) +
                               u[size_t(i)] * dot * (1 - std::cos(ang));
        out.push_back(q);
    }
    return out;
}

CameraPose volcanitePose(const Vec3& centre, const Vec3& sides) {
    const double distance = 1.5 * std::max(sides[0], std::max(sides[1], sides[2]));
    const double elevation = 0.5, azimuth = 4.0;
    CameraPose p;
    p.center = centre;
    p.eye = {centre[0] + distance * std::cos(elevation) * std::cos(azimuth),
             centre[1] + distance * std::cos(elevation) * std::sin(azimuth), centre[2] + distance * std::sin(elevation)};
    p.up = {0, 0, 1};
    p.fovY = 0.33 * 180.0;
    return p;
}

} // namespace csgv
