// Golden images: small renders of fixed scenes compared pixel by pixel with committed PNGs
// (tests/render/golden/*.png). A pixel matches when every channel is within kTolerance; up to
// kAllowedFraction of the pixels may differ more (edge pixels move between llvmpipe versions).
// On a mismatch the actual image and a difference image are written to
// <build>/tests/render/golden_out/. To regenerate after an intended change:
//   PLIANT_UPDATE_GOLDENS=1 ./test_render_golden_image_test   (then review and commit the PNGs)
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "render/offscreen_renderer.h"
#include "render/png_writer.h"
#include "render/render_snapshot.h"
#include "sim/mesh/box_mesh.h"
#include "sim/world.h"

namespace pliant {
namespace {

constexpr int kWidth = 96;
constexpr int kHeight = 72;
constexpr int kTolerance = 10;             // per channel, out of 255
constexpr double kAllowedFraction = 0.01;  // of all pixels

BodyId add_box(World& world, const Vec3& size, int cells, const Vec3& centre, const std::string& name) {
  BodyDef def;
  def.name = name;
  def.mesh = make_box_mesh({size, cells, cells, cells});
  def.motion = BodyMotion::kinematic;
  def.pose.translation = centre;
  def.pose.rotation = Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ()));
  return world.add_body(std::move(def));
}

// A tissue-like slab and a small instrument above it.
RenderSnapshot scene() {
  World world;
  add_box(world, Vec3(0.6, 0.4, 0.15), 3, Vec3::Zero(), "tissue");
  add_box(world, Vec3(0.08, 0.08, 0.25), 1, Vec3(0.05, 0.0, 0.22), "probe");
  SnapshotOptions options;
  options.body_colours = {{"tissue", Rgba8{222, 132, 120, 255}}};
  return take_snapshot(world, options);
}

void expect_matches_golden(const Image& actual, const std::string& name) {
  const std::filesystem::path golden = std::filesystem::path(PLIANT_SOURCE_DIR) / "tests/render/golden" / (name + ".png");
  const char* update = std::getenv("PLIANT_UPDATE_GOLDENS");
  if (update != nullptr && update[0] == '1') {
    write_png(actual, golden);
    GTEST_SKIP() << "wrote " << golden;
  }
  ASSERT_TRUE(std::filesystem::exists(golden))
      << golden << " is missing; generate it with PLIANT_UPDATE_GOLDENS=1 and commit it";
  const Image expected = read_png(golden);
  ASSERT_EQ(expected.width, actual.width);
  ASSERT_EQ(expected.height, actual.height);
  const ImageDifference d = compare_images(actual, expected, kTolerance);
  const long allowed = static_cast<long>(kAllowedFraction * actual.width * actual.height);
  if (d.pixels_over_tolerance > allowed) {
    const std::filesystem::path out = std::filesystem::path(PLIANT_BINARY_DIR) / "tests/render/golden_out";
    std::filesystem::create_directories(out);
    write_png(actual, out / (name + "_actual.png"));
    write_png(d.difference, out / (name + "_diff.png"));
    ADD_FAILURE() << name << ": " << d.pixels_over_tolerance << " pixels differ by more than " << kTolerance
                  << " (allowed " << allowed << "), largest difference " << d.max_channel_difference
                  << "; see " << out;
  }
}

class GoldenImageTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { renderer_ = new OffscreenRenderer(kWidth, kHeight); }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  static OffscreenRenderer* renderer_;
};
OffscreenRenderer* GoldenImageTest::renderer_ = nullptr;

TEST_F(GoldenImageTest, FrontView) {
  ViewSettings view;
  Camera camera;
  camera.position = Vec3(0.0, -1.6, 0.1);
  camera.target = Vec3(0.0, 0.0, 0.05);
  view.camera = camera;
  view.text = false;
  expect_matches_golden(renderer_->render(scene(), view), "front");
}

TEST_F(GoldenImageTest, AutomaticViewWithWireframeAndField) {
  RenderSnapshot snap = scene();
  // Height above the slab's bottom as the field, so the colour map runs bottom to top.
  for (auto& body : snap.bodies) {
    if (body.kinematic && body.name == "probe") continue;
    body.scalar_field.clear();
    for (const Vec3& x : body.positions) body.scalar_field.push_back(x.z() + 0.075);
  }
  snap.field_name = "H (M)";
  snap.field_min = 0.0;
  snap.field_max = 0.15;
  ViewSettings view;
  view.wireframe = true;
  view.text = false;
  expect_matches_golden(renderer_->render(snap, view), "auto_wireframe_field");
}

TEST_F(GoldenImageTest, ContactsArrowsAndText) {
  RenderSnapshot snap = scene();
  snap.contact_points = {Vec3(0.05, 0.0, 0.075), Vec3(0.09, 0.03, 0.075), Vec3(0.01, -0.03, 0.075)};
  snap.arrows = {ForceArrow{Vec3(0.05, 0.0, 0.075), Vec3(0.0, 0.0, 0.2), Rgba8{255, 220, 40, 255}}};
  snap.overlay_lines = {"T 0.0125 S", "PROBE F 1.50 N"};
  Camera camera;
  camera.position = Vec3(0.9, -1.2, 0.8);
  camera.target = Vec3(0.0, 0.0, 0.05);
  ViewSettings view;
  view.camera = camera;
  expect_matches_golden(renderer_->render(snap, view), "contacts_arrows_text");
}

}  // namespace
}  // namespace pliant
