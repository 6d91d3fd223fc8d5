// FrameRecorder: the synchronous mode writes exactly the frames of every k-th step, each the same
// image a direct render gives; the asynchronous mode accounts for every submitted frame (written
// or dropped, files exactly for the accepted ones) and matches the synchronous output when nothing
// is dropped; write failures surface as RenderError.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "render/frame_recorder.h"
#include "render/png_writer.h"
#include "render/render_error.h"
#include "sim/mesh/box_mesh.h"
#include "sim/world.h"

namespace pliant {
namespace {

namespace fs = std::filesystem;

fs::path fresh_folder(const std::string& name) {
  const fs::path folder = fs::path(PLIANT_BINARY_DIR) / "tests/render/frame_recorder_out" / name;
  fs::remove_all(folder);
  return folder;
}

std::set<std::string> files_in(const fs::path& folder) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) names.insert(entry.path().filename().string());
  return names;
}

struct MovingBoxScene {
  World world;
  BodyId box;
  MovingBoxScene() {
    BodyDef def;
    def.name = "box";
    def.mesh = make_box_mesh({Vec3(0.2, 0.2, 0.2), 1, 1, 1});
    def.motion = BodyMotion::kinematic;
    box = world.add_body(std::move(def));
  }
  // Moves the box 1 cm along x per step.
  void step() {
    Pose pose = world.body(box).pose;
    pose.translation.x() += 0.01;
    world.set_kinematic_pose(box, pose);
    const StepReport& report = world.step(1e-3);
    EXPECT_EQ(report.fault, StepFault::none) << report.fault_message;
  }
};

FrameRecorderSettings small(const fs::path& folder) {
  FrameRecorderSettings s;
  s.folder = folder;
  s.width = 48;
  s.height = 32;
  return s;
}

TEST(FrameRecorder, SynchronousWritesEveryKthStepAsTheDirectRender) {
  const fs::path folder = fresh_folder("sync");
  FrameRecorderSettings settings = small(folder);
  settings.every_k_steps = 3;
  settings.view.text = false;
  FrameRecorder recorder(settings);
  MovingBoxScene scene;
  OffscreenRenderer direct(settings.width, settings.height, settings.samples);
  std::vector<RenderSnapshot> expected;
  EXPECT_TRUE(recorder.record(scene.world));  // step 0 -> frame 0
  expected.push_back(take_snapshot(scene.world));
  for (int i = 1; i <= 10; ++i) {
    scene.step();
    const bool recorded = recorder.record(scene.world);
    EXPECT_EQ(recorded, i % 3 == 0) << "step " << i;
    if (recorded) expected.push_back(take_snapshot(scene.world));
  }
  recorder.finish();
  EXPECT_EQ(recorder.frames_written(), 4);
  EXPECT_EQ(recorder.frames_dropped(), 0);
  EXPECT_EQ(files_in(folder), (std::set<std::string>{"frame_000000.png", "frame_000001.png", "frame_000002.png",
                                                       "frame_000003.png"}));
  // The camera was fixed by the first frame; the same camera gives the same pixels directly.
  ASSERT_TRUE(recorder.settings().view.camera.has_value());
  for (size_t k = 0; k < expected.size(); ++k) {
    const Image written = read_png(FrameRecorder::frame_path(folder, static_cast<long>(k)));
    EXPECT_TRUE(written == direct.render(expected[k], recorder.settings().view)) << "frame " << k;
  }
  // The box moved right, so frames differ.
  EXPECT_FALSE(read_png(FrameRecorder::frame_path(folder, 0)) == read_png(FrameRecorder::frame_path(folder, 3)));
}

TEST(FrameRecorder, AsynchronousAccountsForEveryFrame) {
  const fs::path folder = fresh_folder("async_drop");
  FrameRecorderSettings settings = small(folder);
  settings.asynchronous = true;
  settings.queue_capacity = 2;
  FrameRecorder recorder(settings);
  MovingBoxScene scene;
  std::set<std::string> accepted;
  constexpr int kFrames = 40;
  for (int i = 0; i < kFrames; ++i) {
    scene.step();
    if (recorder.submit(take_snapshot(scene.world), i)) accepted.insert(FrameRecorder::frame_path(folder, i).filename().string());
  }
  recorder.finish();
  EXPECT_EQ(recorder.frames_written() + recorder.frames_dropped(), kFrames);
  EXPECT_EQ(recorder.frames_written(), static_cast<long>(accepted.size()));
  EXPECT_GE(recorder.frames_written(), 2);  // the queue starts empty
  EXPECT_EQ(files_in(folder), accepted);
}

TEST(FrameRecorder, AsynchronousWithoutDropsMatchesSynchronous) {
  const fs::path sync_folder = fresh_folder("match_sync");
  const fs::path async_folder = fresh_folder("match_async");
  FrameRecorderSettings sync_settings = small(sync_folder);
  FrameRecorderSettings async_settings = small(async_folder);
  async_settings.asynchronous = true;
  async_settings.queue_capacity = 16;
  {
    FrameRecorder sync(sync_settings);
    FrameRecorder async(async_settings);
    MovingBoxScene scene;
    for (int i = 0; i < 5; ++i) {
      scene.step();
      const RenderSnapshot snap = take_snapshot(scene.world);
      EXPECT_TRUE(sync.submit(snap, i));
      EXPECT_TRUE(async.submit(snap, i));
    }
    async.finish();
    EXPECT_EQ(async.frames_written(), 5);
    EXPECT_EQ(async.frames_dropped(), 0);
  }
  for (long i = 0; i < 5; ++i) {
    EXPECT_TRUE(read_png(FrameRecorder::frame_path(sync_folder, i)) == read_png(FrameRecorder::frame_path(async_folder, i)));
  }
}

TEST(FrameRecorder, UnusableFolderOrLostFolderIsARenderError) {
  const fs::path base = fresh_folder("errors");
  fs::create_directories(base);
  const fs::path file = base / "not_a_folder";
  { std::ofstream(file) << "x"; }
  EXPECT_THROW(FrameRecorder(small(file / "frames")), RenderError);

  // The folder disappears after the recorder started: the worker's failure reaches finish().
  FrameRecorderSettings settings = small(base / "vanishing");
  settings.asynchronous = true;
  FrameRecorder recorder(settings);
  fs::remove_all(base / "vanishing");
  recorder.submit(RenderSnapshot{}, 0);
  EXPECT_THROW(recorder.finish(), RenderError);
  EXPECT_EQ(recorder.frames_written(), 0);
}

}  // namespace
}  // namespace pliant
