#include <btf/core/error.h>
#include <btf/geometry/builders.h>

namespace btf {

TriMesh buildHeightField(double Lx, double Ly, int nx, int ny,
                         const std::function<double(double, double)>& h, bool flat) {
  BTF_CHECK(nx >= 1 && ny >= 1);
  TriMesh m;
  const double dx = Lx / nx, dy = Ly / ny;
  // Vertices on the closed grid [0, Lx] × [0, Ly]; h is periodic so the last row/column match
  // the first exactly in height, and periodic copies join without cracks.
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const double x = i * dx, y = j * dy;
      const double z = h(x, y);
      if (!std::isfinite(z)) throw Error("height field produced a non-finite height");
      m.pos.push_back(Vec3(float(x), float(y), float(z)));
      const double ex = 0.25 * dx, ey = 0.25 * dy;
      const double gx = (h(x + ex, y) - h(x - ex, y)) / (2 * ex);
      const double gy = (h(x, y + ey) - h(x, y - ey)) / (2 * ey);
      m.nrm.push_back(Vec3(glm::normalize(DVec3(-gx, -gy, 1.0))));
    }
  auto id = [&](int i, int j) { return uint32_t(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      m.tri.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.tri.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  if (flat) m.makeFlat();
  return m;
}

}  // namespace btf
