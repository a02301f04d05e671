#pragma once
// Angles (docs/method.md section 1): degrees at the edges (TOML, CSV, JSON, logs), radians inside,
// and on the sweep's lattice an integer index k (theta = k * step) carried from the sweep to the
// edit. Every conversion in the project goes through these, so results do not depend on where an
// angle crossed units.
#include <cmath>
#include <numbers>

namespace amhv::angles {

constexpr double kPi = std::numbers::pi;

inline double radians(double degrees) { return degrees * kPi / 180.0; }
inline double degrees(double radians) { return radians * 180.0 / kPi; }

// To (-180, 180].
inline double wrap_degrees(double degrees) {
    double d = std::fmod(degrees, 360.0);
    if (d > 180.0) d -= 360.0;
    if (d <= -180.0) d += 360.0;
    return d;
}

// To (-pi, pi].
inline double wrap_radians(double a) {
    a = std::fmod(a, 2 * kPi);
    if (a > kPi) a -= 2 * kPi;
    if (a <= -kPi) a += 2 * kPi;
    return a;
}

// The representative of `angle` (mod 2 pi) nearest to `reference`.
inline double nearest_turn(double angle, double reference) { return angle - 2 * kPi * std::round((angle - reference) / (2 * kPi)); }

// |a - b| the short way round, in degrees (0..180).
inline double degrees_apart(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

// The sweep's angle lattice: `count` angles, theta_k = k * step_deg, over the full circle.
struct AngleLattice {
    double step_deg = 2.0;
    int count = 180;

    double degrees(int k) const { return k * step_deg; }
    double radians(int k) const { return angles::radians(degrees(k)); }
    // theta_k wrapped to (-180, 180], as solutions report it.
    double wrapped_degrees(int k) const { return wrap_degrees(degrees(k)); }
    // The index of the lattice angle nearest to `degrees` (any turn), in [0, count).
    int index_of_degrees(double degrees) const {
        const long k = std::lround(degrees / step_deg) % count;
        return int(k < 0 ? k + count : k);
    }
};

}  // namespace amhv::angles
