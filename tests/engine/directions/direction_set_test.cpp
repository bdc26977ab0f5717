#include <btf/core/error.h>
#include <btf/directions/direction_set.h>
#include <gtest/gtest.h>

#include <cmath>

namespace btf {
namespace {

TEST(DirectionSet, CountsAndSolidAnglesOfEverySet) {
  for (auto [name, count] : {std::pair{"bonn81", 81},
                             {"ubo151", 151},
                             {"16x32", 512},
                             {"20x40", 800},
                             {"3x5", 15},
                             {"16x32a", 481},
                             {"8x16a", 113}}) {
    const DirectionSet s = DirectionSet::fromName(name);
    EXPECT_EQ(s.size(), count) << name;
    double sum = 0;
    for (const auto& d : s.dirs()) {
      EXPECT_NEAR(glm::length(d.w), 1.0, 1e-12);
      EXPECT_GE(d.theta, 0);
      EXPECT_LT(d.theta, kPi / 2);
      EXPECT_GT(d.solidAngle, 0);
      sum += d.solidAngle;
    }
    EXPECT_NEAR(sum, 2 * kPi, 1e-9) << name;
  }
}

TEST(DirectionSet, GridUsesCellCentres) {
  const DirectionSet g = DirectionSet::grid(16, 32);
  EXPECT_NEAR(rad2deg(g[0].theta), 90.0 / 32, 1e-12);
  EXPECT_NEAR(rad2deg(g[0].phi), 360.0 / 64, 1e-12);
  EXPECT_NEAR(rad2deg(g[511].theta), 90.0 - 90.0 / 32, 1e-12);
}

TEST(DirectionSet, Ubo151RingsFollowTheFormat) {
  const DirectionSet s = DirectionSet::ubo151();
  ASSERT_EQ(s.rings().size(), 10u);
  EXPECT_NEAR(rad2deg(s.rings()[6].theta), 52.5, 1e-12);
  EXPECT_EQ(s.rings()[6].count, 18);
  EXPECT_NEAR(rad2deg(s[s.rings()[6].first].phi), 7.5, 1e-12);
}

TEST(DirectionSet, InterpolationReproducesNodesAndSumsToOne) {
  for (const char* name : {"bonn81", "ubo151", "8x16", "8x16a"}) {
    const DirectionSet s = DirectionSet::fromName(name);
    for (int i = 0; i < s.size(); ++i) {
      const auto w = s.interpolate(s[i].theta, s[i].phi);
      double total = 0, self = 0;
      for (const auto& x : w) {
        total += x.weight;
        if (x.index == i) self += x.weight;
      }
      EXPECT_NEAR(total, 1, 1e-12);
      EXPECT_NEAR(self, 1, 1e-9) << name << " " << i;
      EXPECT_EQ(s.nearest(s[i].w), i);
    }
    for (double th : {0.0, 0.3, 1.0, 1.5, 1.5707}) {
      for (double ph : {-7.0, 0.0, 2.0, 6.28, 100.0}) {
        double total = 0;
        for (const auto& x : s.interpolate(th, ph)) {
          EXPECT_GE(x.weight, 0);
          total += x.weight;
        }
        EXPECT_NEAR(total, 1, 1e-12);
      }
    }
  }
}

TEST(DirectionSet, AxisGridHasThePoleAndTheAxesOnEveryRing) {
  const DirectionSet s = DirectionSet::fromName("8x16a");
  EXPECT_EQ(s.name(), "8x16a");
  ASSERT_EQ(s.rings().size(), 8u);
  EXPECT_EQ(s[0].theta, 0.0);  // the pole is a direction
  EXPECT_EQ(s.rings()[0].count, 1);
  for (size_t r = 1; r < s.rings().size(); ++r) {
    EXPECT_NEAR(rad2deg(s.rings()[r].theta), 90.0 * double(r) / 8, 1e-12);
    int axes = 0;
    for (int j = 0; j < s.rings()[r].count; ++j) {
      const double ph = rad2deg(s[s.rings()[r].first + j].phi);
      for (double a : {0.0, 90.0, 180.0, 270.0}) axes += std::abs(ph - a) < 1e-9;
    }
    EXPECT_EQ(axes, 4) << "ring " << r;
  }
  // Between the pole and the first ring, interpolation blends the two (continuous at θ = 0).
  const auto w = s.interpolate(deg2rad(5.625), deg2rad(90));
  double pole = 0, axis = 0;
  for (const auto& x : w) (x.index == 0 ? pole : axis) += x.weight;
  EXPECT_NEAR(pole, 0.5, 1e-9);
  EXPECT_NEAR(axis, 0.5, 1e-9);
  EXPECT_THROW(DirectionSet::fromName("8x18a"), Error);  // φ count not a multiple of 4
  EXPECT_THROW(DirectionSet::fromName("1x16a"), Error);
  EXPECT_THROW(DirectionSet::fromName("8x16ab"), Error);
}

TEST(DirectionSet, UnknownNamesAreErrors) {
  EXPECT_THROW(DirectionSet::fromName("bonn80"), Error);
  EXPECT_THROW(DirectionSet::fromName("0x32"), Error);
  EXPECT_THROW(DirectionSet::fromName("16x"), Error);
  try {
    DirectionSet::fromName("utia");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown direction set 'utia'"), std::string::npos);
  }
}

}  // namespace
}  // namespace btf
