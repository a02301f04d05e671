#include "src/core/distance.hpp"

#include <limits>

namespace amhv {

namespace {

double square(double v) { return v * v; }

// One line of the squared distance transform: d[q] = min_p (q - p)^2 + f[p].
void transform_line(std::vector<double>& f, std::vector<double>& d, std::vector<int>& v, std::vector<double>& z) {
    const int n = int(f.size());
    int k = 0;
    v[0] = 0;
    z[0] = -std::numeric_limits<double>::infinity();
    z[1] = std::numeric_limits<double>::infinity();
    // Where the parabola rooted at q meets the one rooted at v[k].
    auto meet = [&](int q) {
        const int p = v[std::size_t(k)];
        return ((f[std::size_t(q)] + double(q) * q) - (f[std::size_t(p)] + double(p) * p)) / (2.0 * q - 2.0 * p);
    };
    for (int q = 1; q < n; ++q) {
        double s = meet(q);
        while (s <= z[std::size_t(k)]) {
            --k;
            s = meet(q);
        }
        ++k;
        v[std::size_t(k)] = q;
        z[std::size_t(k)] = s;
        z[std::size_t(k) + 1] = std::numeric_limits<double>::infinity();
    }
    k = 0;
    for (int q = 0; q < n; ++q) {
        while (z[std::size_t(k) + 1] < q) ++k;
        d[std::size_t(q)] = square(q - v[std::size_t(k)]) + f[std::size_t(v[std::size_t(k)])];
    }
}

}  // namespace

void squared_distance_transform(std::vector<double>& f, const std::array<int, 3>& dims) {
    const std::size_t nx = std::size_t(dims[0]), ny = std::size_t(dims[1]), nz = std::size_t(dims[2]);
    const std::array<std::size_t, 3> stride{1, nx, nx * ny};
    for (int axis = 0; axis < 3; ++axis) {
        const std::size_t n = std::size_t(dims[std::size_t(axis)]);
        std::vector<double> line(n), out(n), z(n + 1);
        std::vector<int> v(n);
        for (std::size_t c = 0; c < nz; ++c)
            for (std::size_t b = 0; b < ny; ++b)
                for (std::size_t a = 0; a < nx; ++a) {
                    const std::size_t at = a + b * nx + c * nx * ny;
                    // Each line once: from its first voxel along the axis.
                    if ((axis == 0 && a != 0) || (axis == 1 && b != 0) || (axis == 2 && c != 0)) continue;
                    for (std::size_t q = 0; q < n; ++q) line[q] = f[at + q * stride[std::size_t(axis)]];
                    transform_line(line, out, v, z);
                    for (std::size_t q = 0; q < n; ++q) f[at + q * stride[std::size_t(axis)]] = out[q];
                }
    }
}

}  // namespace amhv
