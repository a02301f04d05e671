#include "src/body/shapes.hpp"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

namespace amhv::shapes {

namespace {

// Closed surface of revolution around local +z: `profile` lists (radius, height) from the bottom
// pole to the top pole; poles have radius 0 and become single vertices. Outward orientation.
TriangleMesh revolve(const std::vector<std::pair<double, double>>& profile, int segments, const Eigen::Matrix3d& rotation,
                     const Vec3& offset) {
    TriangleMesh mesh;
    const int rings = int(profile.size());
    auto put = [&](double r, double h, double angle) {
        mesh.vertices.push_back(rotation * Vec3(r * std::cos(angle), r * std::sin(angle), h) + offset);
    };
    put(0, profile.front().second, 0);  // bottom pole: vertex 0
    for (int k = 1; k < rings - 1; ++k)
        for (int j = 0; j < segments; ++j) put(profile[std::size_t(k)].first, profile[std::size_t(k)].second, 2 * std::numbers::pi * j / segments);
    put(0, profile.back().second, 0);  // top pole: last vertex
    auto ring = [&](int k, int j) { return std::uint32_t(1 + (k - 1) * segments + (j % segments)); };
    const auto top = std::uint32_t(mesh.vertices.size() - 1);
    for (int j = 0; j < segments; ++j) mesh.triangles.push_back({0u, ring(1, j + 1), ring(1, j)});
    for (int k = 1; k < rings - 2; ++k)
        for (int j = 0; j < segments; ++j) {
            mesh.triangles.push_back({ring(k, j), ring(k, j + 1), ring(k + 1, j + 1)});
            mesh.triangles.push_back({ring(k, j), ring(k + 1, j + 1), ring(k + 1, j)});
        }
    for (int j = 0; j < segments; ++j) mesh.triangles.push_back({top, ring(rings - 2, j), ring(rings - 2, j + 1)});
    return mesh;
}

std::vector<std::pair<double, double>> capsule_profile(double radius, double length, int cap_rings) {
    std::vector<std::pair<double, double>> profile;
    for (int k = 0; k <= cap_rings; ++k) {  // bottom cap, pole to equator
        double a = -std::numbers::pi / 2 + std::numbers::pi / 2 * k / cap_rings;
        profile.emplace_back(radius * std::cos(a), radius * std::sin(a));
    }
    for (int k = 0; k <= cap_rings; ++k) {  // top cap, equator to pole
        double a = std::numbers::pi / 2 * k / cap_rings;
        profile.emplace_back(radius * std::cos(a), length + radius * std::sin(a));
    }
    if (length <= 0) profile.erase(profile.begin() + cap_rings);  // no cylinder: one equator ring
    profile.front().first = 0;
    profile.back().first = 0;
    return profile;
}

// The hull of a sphere of radius ra at height 0 and one of radius rb at height `length`: each
// sphere's part whose outward normal leans past the tangent cone's (polar angle acos((ra - rb) /
// length) from +z), cap_rings rings each, joined by the cone.
std::vector<std::pair<double, double>> tapered_profile(double ra, double rb, double length, int cap_rings) {
    const double tangent = std::acos((ra - rb) / length);
    std::vector<std::pair<double, double>> profile;
    for (int k = 0; k <= cap_rings; ++k) {  // sphere A, bottom pole to the cone
        const double phi = std::numbers::pi - (std::numbers::pi - tangent) * k / cap_rings;
        profile.emplace_back(ra * std::sin(phi), ra * std::cos(phi));
    }
    for (int k = 0; k <= cap_rings; ++k) {  // sphere B, the cone to the top pole
        const double phi = tangent - tangent * k / cap_rings;
        profile.emplace_back(rb * std::sin(phi), length + rb * std::cos(phi));
    }
    profile.front().first = 0;
    profile.back().first = 0;
    return profile;
}

}  // namespace

TriangleMesh sphere(const Vec3& centre, double radius, int rings, int segments) {
    std::vector<std::pair<double, double>> profile;
    for (int k = 0; k <= rings; ++k) {
        double a = -std::numbers::pi / 2 + std::numbers::pi * k / rings;
        profile.emplace_back(k == 0 || k == rings ? 0.0 : radius * std::cos(a), radius * std::sin(a));
    }
    return revolve(profile, segments, Eigen::Matrix3d::Identity(), centre);
}

TriangleMesh capsule(const Vec3& a, const Vec3& b, double radius, int cap_rings, int segments) {
    Vec3 axis = b - a;
    double length = axis.norm();
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    if (length > 0) rotation = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), axis / length).toRotationMatrix();
    return revolve(capsule_profile(radius, length, cap_rings), segments, rotation, a);
}

TriangleMesh tapered_capsule(const Vec3& a, const Vec3& b, double ra, double rb, int cap_rings, int segments) {
    const Vec3 axis = b - a;
    const double length = axis.norm();
    // One sphere holds the other: the hull is the larger sphere.
    if (length <= std::abs(ra - rb)) return ra >= rb ? sphere(a, ra, 2 * cap_rings, segments) : sphere(b, rb, 2 * cap_rings, segments);
    const Eigen::Matrix3d rotation = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), axis / length).toRotationMatrix();
    return revolve(tapered_profile(ra, rb, length, cap_rings), segments, rotation, a);
}

TriangleMesh box(const Vec3& lo, const Vec3& hi) {
    TriangleMesh mesh;
    for (int i = 0; i < 8; ++i) mesh.vertices.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
    // Each face as a quad (counter-clockwise seen from outside).
    const std::uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
        mesh.triangles.push_back({q[0], q[1], q[2]});
        mesh.triangles.push_back({q[0], q[2], q[3]});
    }
    return mesh;
}

TriangleMesh torus(const Vec3& centre, double major_radius, double minor_radius, int major_segments, int minor_segments) {
    TriangleMesh mesh;
    for (int i = 0; i < major_segments; ++i)
        for (int j = 0; j < minor_segments; ++j) {
            double u = 2 * std::numbers::pi * i / major_segments, v = 2 * std::numbers::pi * j / minor_segments;
            double r = major_radius + minor_radius * std::cos(v);
            mesh.vertices.push_back(centre + Vec3(r * std::cos(u), r * std::sin(u), minor_radius * std::sin(v)));
        }
    auto at = [&](int i, int j) { return std::uint32_t((i % major_segments) * minor_segments + (j % minor_segments)); };
    for (int i = 0; i < major_segments; ++i)
        for (int j = 0; j < minor_segments; ++j) {
            mesh.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            mesh.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    return mesh;
}

double signed_volume(const TriangleMesh& mesh) {
    double volume = 0;
    for (const auto& t : mesh.triangles)
        volume += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]]));
    return volume / 6.0;
}

}  // namespace amhv::shapes
