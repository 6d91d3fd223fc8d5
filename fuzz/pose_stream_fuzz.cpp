// libFuzzer target: pose-stream CSV text, line by line through parse_pose_line and whole through
// PoseStream::from_text (per-instrument time order), then played back by a StreamPoseSource.
#include <sstream>

#include "fuzz/fuzz_guard.h"
#include "interaction/pose_stream.h"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  const std::string text = pliant::fuzz::as_text(data, size);
  pliant::fuzz::expect_only_input_errors("pose_stream_fuzz", [&] {
    std::istringstream in(text);
    std::string line, instrument;
    pliant::PoseSample sample;
    while (std::getline(in, line)) {
      try {
        pliant::parse_pose_line(line, "fuzz:1", instrument, sample);
      } catch (const pliant::InputError&) {
      }
    }
  });
  pliant::fuzz::expect_only_input_errors("pose_stream_fuzz", [&] {
    auto stream = pliant::PoseStream::from_text(text, "fuzz.csv");
    pliant::StreamPoseSource source(stream, "probe", pliant::InstrumentCommand{});
    for (int k = 0; k <= 8; ++k) source.sample(0.25 * k, pliant::InstrumentFeedback{});
  });
  return 0;
}
