// Pose streams and force sinks: a recorded stream drives instruments exactly as the script that
// produced it, bad lines name source:line, UDP on loopback carries poses in and forces out.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "interaction/force_sink.h"
#include "interaction/pose_stream.h"
#include "interaction/script_pose_source.h"

namespace pliant {
namespace {

using nlohmann::json;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("pliant_pose_stream_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

InstrumentSpec probe_spec() {
  return parse_instrument_spec(JsonReader(json{{"name", "probe"}, {"type", "probe"}, {"tip_radius", 0.004},
                                               {"position", {0.0, 0.0, 0.05}}},
                                          "scene.json", "/instruments/0"));
}
InstrumentSpec grasper_spec() {
  return parse_instrument_spec(JsonReader(json{{"name", "grasper"}, {"type", "grasper"}, {"jaw_length", 0.02},
                                               {"jaw_width", 0.004}, {"jaw_thickness", 0.002}},
                                          "scene.json", "/instruments/1"));
}

const json kScript = json::parse(R"([
  {"t": 0.3, "instrument": "probe", "op": "move", "position": [0.01, 0.02, 0.03]},
  {"t": 0.6, "instrument": "probe", "op": "press", "axis": [0, 0, -1], "depth": 0.01},
  {"t": 0.9, "instrument": "probe", "op": "slide", "path": [[0.03, 0.02, 0.02], [0.03, 0.05, 0.02]]},
  {"t": 1.2, "instrument": "probe", "op": "rotate", "axis": [1, 1, 0], "angle_deg": 30},
  {"t": 0.5, "instrument": "grasper", "op": "jaws", "opening_deg": 40},
  {"t": 1.0, "instrument": "grasper", "op": "rotate", "axis": [0, 0, 1], "angle_deg": -20}
])");

// Runs `sources` on a world of the two instruments for `ticks` ticks of dt; returns every body's
// vertex positions after every step, flattened.
std::vector<Vec3> drive(std::vector<std::unique_ptr<PoseSource>>& sources, int ticks, double dt,
                        const std::function<void(double, const std::string&, const InstrumentCommand&)>& record = {}) {
  World world;
  std::vector<Instrument> tools{Instrument::create(world, probe_spec()), Instrument::create(world, grasper_spec())};
  std::vector<Vec3> trace;
  for (int i = 1; i <= ticks; ++i) {
    const double t = i * dt;
    for (size_t k = 0; k < tools.size(); ++k) {
      const InstrumentCommand c = sources[k]->sample(t, InstrumentFeedback{});
      if (record) record(t, tools[k].name(), c);
      tools[k].apply(world, c);
    }
    world.step(dt);
    for (const Instrument& tool : tools) {
      for (BodyId id : tool.bodies()) {
        const auto& x = world.body(id).positions;
        trace.insert(trace.end(), x.begin(), x.end());
      }
    }
  }
  return trace;
}

TEST(PoseStream, RecordedStreamDrivesInstrumentsExactlyAsTheScript) {
  const ToolScript script = parse_tool_script(JsonReader(kScript, "scene.json", "/script"), {"probe", "grasper"});
  const double dt = 1e-3;
  const int ticks = 1300;
  std::vector<std::unique_ptr<PoseSource>> scripted;
  const InstrumentCommand probe0{probe_spec().pose, 0.0}, grasper0{grasper_spec().pose, 0.0};
  scripted.push_back(std::make_unique<ScriptPoseSource>(script, "probe", probe0));
  scripted.push_back(std::make_unique<ScriptPoseSource>(script, "grasper", grasper0));
  const std::string path = temp_path("recorded.csv");
  std::ofstream out(path);
  out << "# t,instrument,x,y,z,qw,qx,qy,qz,jaw\n";
  const std::vector<Vec3> expected =
      drive(scripted, ticks, dt, [&](double t, const std::string& name, const InstrumentCommand& c) {
        out << format_pose_line(t, name, c) << "\n";
      });
  out.close();

  auto stream = PoseStream::open("file:" + path);
  std::vector<std::unique_ptr<PoseSource>> streamed;
  streamed.push_back(std::make_unique<StreamPoseSource>(stream, "probe", probe0));
  streamed.push_back(std::make_unique<StreamPoseSource>(stream, "grasper", grasper0));
  const std::vector<Vec3> replayed = drive(streamed, ticks, dt);
  ASSERT_EQ(replayed.size(), expected.size());
  size_t differing = 0;
  for (size_t i = 0; i < expected.size(); ++i) differing += (replayed[i].array() != expected[i].array()).any();
  EXPECT_EQ(differing, 0u);  // bit for bit
  EXPECT_TRUE(streamed[0]->finished(ticks * dt));
  EXPECT_FALSE(streamed[0]->finished(0.5));
  std::filesystem::remove(path);
}

TEST(PoseStream, InterpolatesBetweenSamplesAndHoldsOutside) {
  auto stream = PoseStream::from_text(
      "0.0,probe,0,0,0,1,0,0,0,0\n"
      "1.0,probe,1,2,3,0,0,0,1,0.5\n",
      "mem.csv");
  StreamPoseSource src(stream, "probe", InstrumentCommand{});
  EXPECT_EQ(src.sample(-1.0, {}).pose.translation, Vec3(0, 0, 0));
  const InstrumentCommand mid = src.sample(0.25, {});
  EXPECT_NEAR((mid.pose.translation - Vec3(0.25, 0.5, 0.75)).norm(), 0.0, 1e-15);
  EXPECT_NEAR(mid.jaw_opening, 0.125, 1e-15);
  // Slerp from identity to 180 deg about z: a quarter of the way is 45 deg.
  EXPECT_NEAR(mid.pose.rotation.angularDistance(Quat(Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ()))), 0.0, 1e-12);
  EXPECT_EQ(src.sample(5.0, {}).pose.translation, Vec3(1, 2, 3));
  // The jaw column is optional: missing means "as before".
  auto s2 = PoseStream::from_text("0,g,0,0,0,1,0,0,0,0.3\n1,g,0,0,0,1,0,0,0\n", "mem2.csv");
  EXPECT_EQ(s2->samples("g")[1].command.jaw_opening, 0.3);
}

void expect_stream_error(const std::string& text, const std::string& where, InputErrorKind kind) {
  try {
    PoseStream::from_text(text, "poses.csv");
    ADD_FAILURE() << "no error for " << text;
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), where) << e.what();
    EXPECT_EQ(e.kind(), kind) << e.what();
  }
}

TEST(PoseStream, BadLinesNameSourceAndLine) {
  const std::string good = "# header\n0,probe,0,0,0,1,0,0,0\n";
  expect_stream_error(good + "0.1,probe,0,0,zero,1,0,0,0\n", "poses.csv:3", InputErrorKind::syntax);
  expect_stream_error(good + "\n0.1,probe,0,0,0,1,0,0\n", "poses.csv:4", InputErrorKind::syntax);
  expect_stream_error(good + "0.1,probe,0,0,0,0,0,0,0\n", "poses.csv:3", InputErrorKind::bad_value);
  expect_stream_error(good + "0.0,probe,0,0,0,1,0,0,0\n", "poses.csv:3", InputErrorKind::bad_value);
  expect_stream_error(good + "0.1,probe,0,0,nan,1,0,0,0\n", "poses.csv:3", InputErrorKind::non_finite);
  expect_stream_error(good + "0.1,,0,0,0,1,0,0,0\n", "poses.csv:3", InputErrorKind::syntax);
  try {
    PoseStream::open("file:/nonexistent/poses.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::io);
  }
}

TEST(PoseStream, UdpLoopbackDeliversLivePoses) {
  auto stream = PoseStream::open("udp:0");
  ASSERT_GT(stream->port(), 0);
  StreamPoseSource src(stream, "probe", InstrumentCommand{});
  EXPECT_EQ(src.sample(0.0, {}).pose.translation, Vec3::Zero());  // nothing yet: initial

  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(stream->port()));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const std::string datagram = "10.0,probe,1,2,3,1,0,0,0\n10.001,probe,4,5,6,1,0,0,0";
  ASSERT_GT(::sendto(fd, datagram.data(), datagram.size(), 0, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  InstrumentCommand c;
  for (int attempt = 0; attempt < 1000 && c.pose.translation.isZero(); ++attempt) {
    c = src.sample(0.001, {});
    if (c.pose.translation.isZero()) ::usleep(1000);
  }
  EXPECT_EQ(c.pose.translation, Vec3(4, 5, 6));  // the latest sample
  EXPECT_EQ(stream->samples("probe").size(), 2u);

  const std::string bad = "10.002,probe,1,2";
  ::sendto(fd, bad.data(), bad.size(), 0, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  bool thrown = false;
  for (int attempt = 0; attempt < 1000 && !thrown; ++attempt) {
    try {
      src.sample(0.002, {});
      ::usleep(1000);
    } catch (const InputError& e) {
      thrown = true;
      EXPECT_EQ(e.where(), "udp:" + std::to_string(stream->port()) + ":3");
    }
  }
  EXPECT_TRUE(thrown);
  ::close(fd);
}

TEST(ForceSink, FileLinesParseBackExactly) {
  const std::string path = temp_path("forces.csv");
  {
    auto sink = ForceSink::open(path);
    sink->write(0.001, "probe", Vec3(0.1, -2.0 / 3.0, 1e-300), Vec3(1, 2, 3));
    sink->write(0.002, "grasper", Vec3(1, 2, 3), Vec3(-0.1, 0.2, -0.3));
  }
  std::ifstream in(path);
  std::string header, line;
  std::getline(in, header);
  EXPECT_EQ(header, "t,instrument,fx,fy,fz,tx,ty,tz");
  std::getline(in, line);
  std::stringstream fields(line);
  std::string f;
  std::vector<std::string> parts;
  while (std::getline(fields, f, ',')) parts.push_back(f);
  ASSERT_EQ(parts.size(), 8u);
  EXPECT_EQ(parts[1], "probe");
  EXPECT_EQ(std::stod(parts[3]), -2.0 / 3.0);
  EXPECT_EQ(std::stod(parts[4]), 1e-300);
  std::getline(in, line);
  EXPECT_EQ(line.substr(0, 13), "0.002,grasper");
  std::filesystem::remove(path);
}

TEST(ForceSink, UdpSendsOneLinePerDatagram) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = 0;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  auto sink = ForceSink::open("udp:" + std::to_string(ntohs(addr.sin_port)));
  sink->write(1.5, "probe", Vec3(1, 0, 0), Vec3(0, 0, 0));
  char buffer[512];
  const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
  ASSERT_GT(n, 0);
  EXPECT_EQ(std::string(buffer, static_cast<size_t>(n)), format_force_line(1.5, "probe", Vec3(1, 0, 0), Vec3::Zero()));
  ::close(fd);
}

}  // namespace
}  // namespace pliant
