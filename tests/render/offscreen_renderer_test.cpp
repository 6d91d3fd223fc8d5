// OffscreenRenderer against geometry computed independently of GL: background at the corners,
// the pixel count of a box against the area of its projected silhouette (convex hull of the
// projected corners), the centroid shift of a moved body against the projected shift, occlusion
// by depth regardless of draw order, and bitwise determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "render/camera.h"
#include "render/offscreen_renderer.h"
#include "render/render_error.h"
#include "render/render_snapshot.h"
#include "sim/mesh/box_mesh.h"
#include "sim/world.h"

namespace pliant {
namespace {

constexpr int kWidth = 64;
constexpr int kHeight = 48;
constexpr Rgba8 kBackground{10, 20, 30, 255};

// A kinematic box (no deformation model needed) of edge `size` centred at `centre`.
BodyId add_box(World& world, double size, const Vec3& centre, const std::string& name) {
  BodyDef def;
  def.name = name;
  def.mesh = make_box_mesh({Vec3::Constant(size), 2, 2, 2});
  def.motion = BodyMotion::kinematic;
  def.pose.translation = centre;
  return world.add_body(std::move(def));
}

// Looking along +y from y = -2 (front view), z up.
Camera front_camera() {
  Camera c;
  c.position = Vec3(0.0, -2.0, 0.0);
  c.target = Vec3::Zero();
  c.up = Vec3::UnitZ();
  c.fov_y_deg = 30.0;
  return c;
}

ViewSettings plain_view(const Camera& camera) {
  ViewSettings v;
  v.camera = camera;
  v.background = kBackground;
  v.text = false;
  v.legend = false;
  return v;
}

struct PixelStats {
  long count = 0;
  Vec2 centroid = Vec2::Zero();
};

// Pixels that differ from the background, and their centroid (pixel centres).
PixelStats foreground(const Image& image) {
  PixelStats s;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (image.pixel(x, y) == kBackground) continue;
      ++s.count;
      s.centroid += Vec2(x + 0.5, y + 0.5);
    }
  }
  if (s.count > 0) s.centroid /= static_cast<double>(s.count);
  return s;
}

// Area and perimeter (pixels^2, pixels) of the convex hull of points (monotone chain).
std::pair<double, double> hull_area_perimeter(std::vector<Vec2> p) {
  std::sort(p.begin(), p.end(), [](const Vec2& a, const Vec2& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  const auto cross = [](const Vec2& o, const Vec2& a, const Vec2& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::vector<Vec2> hull(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], p[i - 1]) <= 0) --k;
    hull[k++] = p[i - 1];
  }
  hull.resize(k - 1);
  double area = 0.0, perimeter = 0.0;
  for (size_t i = 0; i < hull.size(); ++i) {
    const Vec2& a = hull[i];
    const Vec2& b = hull[(i + 1) % hull.size()];
    area += a.x() * b.y() - b.x() * a.y();
    perimeter += (b - a).norm();
  }
  return {0.5 * std::abs(area), perimeter};
}

std::vector<Vec2> projected_corners(const Camera& camera, const Vec3& centre, double size) {
  std::vector<Vec2> out;
  for (int c = 0; c < 8; ++c) {
    const Vec3 offset((c & 1) ? 0.5 : -0.5, (c & 2) ? 0.5 : -0.5, (c & 4) ? 0.5 : -0.5);
    out.push_back(camera.project_to_pixel(centre + size * offset, kWidth, kHeight));
  }
  return out;
}

class OffscreenRendererTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { renderer_ = new OffscreenRenderer(kWidth, kHeight); }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  static OffscreenRenderer* renderer_;
};
OffscreenRenderer* OffscreenRendererTest::renderer_ = nullptr;

TEST_F(OffscreenRendererTest, ContextIsOpenGl33OrLater) {
  int major = 0, minor = 0;
  ASSERT_EQ(std::sscanf(renderer_->gl_version().c_str(), "%d.%d", &major, &minor), 2) << renderer_->gl_version();
  EXPECT_GE(major * 10 + minor, 33);
  EXPECT_FALSE(renderer_->gl_renderer().empty());
}

TEST_F(OffscreenRendererTest, EmptySceneIsBackgroundEverywhere) {
  const Image image = renderer_->render(RenderSnapshot{}, plain_view(front_camera()));
  ASSERT_EQ(image.width, kWidth);
  ASSERT_EQ(image.height, kHeight);
  EXPECT_EQ(foreground(image).count, 0);
}

TEST_F(OffscreenRendererTest, BoxCoversItsProjectedAreaAndCornersAreBackground) {
  for (const double size : {0.3, 0.5, 0.7}) {
    World world;
    add_box(world, size, Vec3::Zero(), "box");
    const Camera camera = front_camera();
    const Image image = renderer_->render(take_snapshot(world), plain_view(camera));
    for (const auto& [x, y] : {std::pair{0, 0}, {kWidth - 1, 0}, {0, kHeight - 1}, {kWidth - 1, kHeight - 1}}) {
      EXPECT_EQ(image.pixel(x, y), kBackground) << "corner " << x << "," << y;
    }
    // A pixel is covered when its centre is inside the silhouette: the count can differ from the
    // area by at most about one pixel row along the outline.
    const auto [area, perimeter] = hull_area_perimeter(projected_corners(camera, Vec3::Zero(), size));
    const PixelStats stats = foreground(image);
    EXPECT_GT(area, 50.0);
    EXPECT_NEAR(static_cast<double>(stats.count), area, 0.5 * perimeter + 2.0) << "size " << size;
    EXPECT_NEAR(stats.centroid.x(), 0.5 * kWidth, 0.5);
    EXPECT_NEAR(stats.centroid.y(), 0.5 * kHeight, 0.5);
  }
}

TEST_F(OffscreenRendererTest, MovingTheBodyShiftsItsCentroidByTheProjectedShift) {
  const Camera camera = front_camera();
  const double size = 0.3;
  const Vec2 start = foreground([&] {
                       World world;
                       add_box(world, size, Vec3::Zero(), "box");
                       return renderer_->render(take_snapshot(world), plain_view(camera));
                     }()).centroid;
  // Right (+x) and up (+z) in the world are right (+column) and up (-row) in the image.
  for (const Vec3& move : {Vec3(0.2, 0.0, 0.0), Vec3(0.0, 0.0, 0.15), Vec3(-0.25, 0.0, -0.1)}) {
    World world;
    add_box(world, size, move, "box");
    const Vec2 moved = foreground(renderer_->render(take_snapshot(world), plain_view(camera))).centroid;
    const auto corners = projected_corners(camera, move, size);
    const auto corners0 = projected_corners(camera, Vec3::Zero(), size);
    // Centroid of the silhouette of a box seen head on: the centre of its front face's projection.
    Vec2 expected = Vec2::Zero(), expected0 = Vec2::Zero();
    for (int c = 0; c < 8; ++c) {
      if ((c & 2) == 0) {  // front face (y = -size/2)
        expected += 0.25 * corners[static_cast<size_t>(c)];
        expected0 += 0.25 * corners0[static_cast<size_t>(c)];
      }
    }
    const Vec2 shift = moved - start;
    EXPECT_NEAR(shift.x(), (expected - expected0).x(), 0.6) << move.transpose();
    EXPECT_NEAR(shift.y(), (expected - expected0).y(), 0.6) << move.transpose();
    EXPECT_EQ(shift.x() > 0.5, move.x() > 0.0);
    EXPECT_EQ(shift.y() < -0.5, move.z() > 0.0);
  }
}

TEST_F(OffscreenRendererTest, NearerBodyOccludesFartherOneWhateverTheDrawOrder) {
  const Camera camera = front_camera();
  const Rgba8 red{230, 30, 30, 255};
  const Rgba8 blue{30, 30, 230, 255};
  for (const bool near_first : {true, false}) {
    World world;
    // The near box (y = -0.5) covers the image centre; the far one (y = +0.5) is twice as large.
    const Vec3 near_centre(0.0, -0.5, 0.0), far_centre(0.0, 0.5, 0.0);
    if (near_first) {
      add_box(world, 0.2, near_centre, "near");
      add_box(world, 0.6, far_centre, "far");
    } else {
      add_box(world, 0.6, far_centre, "far");
      add_box(world, 0.2, near_centre, "near");
    }
    SnapshotOptions options;
    options.body_colours = {{"near", red}, {"far", blue}};
    const Image image = renderer_->render(take_snapshot(world, options), plain_view(camera));
    const Rgba8 centre = image.pixel(kWidth / 2, kHeight / 2);
    EXPECT_GT(centre.r, 3 * centre.b) << "near box must be in front (near_first " << near_first << ")";
    // Just outside the near box's silhouette but inside the far one's: blue.
    const auto near_hull = projected_corners(camera, near_centre, 0.2);
    double near_right = 0.0;
    for (const Vec2& p : near_hull) near_right = std::max(near_right, p.x());
    const Rgba8 beside = image.pixel(static_cast<int>(near_right) + 2, kHeight / 2);
    EXPECT_GT(beside.b, 3 * beside.r);
  }
}

TEST_F(OffscreenRendererTest, SameStateRendersBitwiseIdentically) {
  World world;
  add_box(world, 0.4, Vec3(0.05, 0.0, 0.02), "a");
  add_box(world, 0.2, Vec3(-0.2, -0.3, 0.1), "b");
  const RenderSnapshot snap = take_snapshot(world);
  ViewSettings view;  // automatic camera, text and all
  view.wireframe = true;
  const Image first = renderer_->render(snap, view);
  const Image second = renderer_->render(snap, view);
  EXPECT_TRUE(first == second);
  OffscreenRenderer other(kWidth, kHeight);
  EXPECT_TRUE(other.render(snap, view) == first) << "a second context must agree too";
}

TEST_F(OffscreenRendererTest, AutomaticCameraKeepsTheWholeSceneInView) {
  World world;
  add_box(world, 0.4, Vec3(1.0, 2.0, 3.0), "a");
  add_box(world, 0.1, Vec3(1.6, 2.1, 2.8), "b");
  const RenderSnapshot snap = take_snapshot(world);
  const Camera camera = frame_bounds(snap.bounds(), static_cast<double>(kWidth) / kHeight);
  const Aabb box = snap.bounds();
  for (int c = 0; c < 8; ++c) {
    const Vec3 p((c & 1) ? box.max.x() : box.min.x(), (c & 2) ? box.max.y() : box.min.y(), (c & 4) ? box.max.z() : box.min.z());
    const Vec2 q = camera.project_to_pixel(p, kWidth, kHeight);
    EXPECT_GE(q.x(), 0.0);
    EXPECT_LE(q.x(), kWidth);
    EXPECT_GE(q.y(), 0.0);
    EXPECT_LE(q.y(), kHeight);
  }
  ViewSettings view = plain_view(camera);
  view.camera.reset();  // the renderer must pick the same framing itself
  const PixelStats stats = foreground(renderer_->render(snap, view));
  EXPECT_GT(stats.count, 20);
  for (const auto& [x, y] : {std::pair{0, 0}, {kWidth - 1, 0}, {0, kHeight - 1}, {kWidth - 1, kHeight - 1}}) {
    EXPECT_EQ(renderer_->render(snap, view).pixel(x, y), kBackground);
  }
}

TEST_F(OffscreenRendererTest, MultisamplingChangesOnlyPixelsAtEdges) {
  World world;
  add_box(world, 0.4, Vec3(0.03, 0.0, 0.01), "box");
  SnapshotOptions white;
  white.body_colours = {{"box", Rgba8{255, 255, 255, 255}}};
  const RenderSnapshot snap = take_snapshot(world, white);
  ViewSettings view = plain_view(front_camera());
  view.camera->position = Vec3(0.8, -1.8, 0.6);  // oblique, so edges are slanted
  const Image aliased = renderer_->render(snap, view);
  OffscreenRenderer msaa(kWidth, kHeight, 4);
  EXPECT_EQ(msaa.samples(), 4);
  const Image smooth = msaa.render(snap, view);
  // A pixel whose 3x3 neighbourhood is uniform in the aliased image lies away from every edge and
  // must come out the same (all samples see the same surface and nearly the same shading).
  long changed = 0;
  for (int y = 1; y + 1 < kHeight; ++y) {
    for (int x = 1; x + 1 < kWidth; ++x) {
      const Rgba8 a = aliased.pixel(x, y);
      const Rgba8 b = smooth.pixel(x, y);
      const int diff = std::max({std::abs(a.r - b.r), std::abs(a.g - b.g), std::abs(a.b - b.b)});
      bool background_neighbourhood = true, any_background = false;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const bool bg = aliased.pixel(x + dx, y + dy) == kBackground;
          background_neighbourhood = background_neighbourhood && bg;
          any_background = any_background || bg;
        }
      }
      if (background_neighbourhood) {
        EXPECT_EQ(b, kBackground) << x << "," << y;
      }
      if (!any_background) {
        EXPECT_LE(diff, 24) << "interior pixel " << x << "," << y;
      }
      if (diff > 24) ++changed;
    }
  }
  EXPECT_GT(changed, 10) << "the silhouette must be anti-aliased";
  EXPECT_TRUE(msaa.render(snap, view) == smooth) << "multisampling stays deterministic";
}

TEST(OffscreenRendererErrors, ImpossibleSizesGiveAClearRenderError) {
  EXPECT_THROW(OffscreenRenderer(0, 10), RenderError);
  try {
    OffscreenRenderer huge(100000, 8);
    FAIL() << "a 100000-pixel-wide buffer must be refused";
  } catch (const RenderError& e) {
    EXPECT_NE(std::string(e.what()).find("OSMesa"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pliant
