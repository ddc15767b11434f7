// GestureRecognition's PointsCloud feature (stand-in): segments a synthetic depth cloud at
// 15 Hz and reports the clusters it found in the last frame. One source for both bindings
// (see hands.hpp).
#ifndef MOTIVML_FEATURES_POINTSCLOUD_HPP
#define MOTIVML_FEATURES_POINTSCLOUD_HPP

#include <string>

#include <motivml/feature.hpp>

namespace gestures {

class PointsCloud : public motivml::Feature {
 public:
  void step(double time, motivml::Spaces&) override {
    const long frame = static_cast<long>(time * 15.0);
    if (frame != frame_) {
      frame_ = frame;
      clusters_ = 1 + static_cast<int>(frame % 4);
      ++frames_;
    }
  }
  std::string status() const override {
    return std::to_string(frames_) + " depth frames, " + std::to_string(clusters_) + " clusters";
  }

 private:
  long frame_ = -1;
  long frames_ = 0;
  int clusters_ = 0;
};

}  // namespace gestures

MOTIVML_FEATURE(pointscloud, gestures::PointsCloud)

#endif  // MOTIVML_FEATURES_POINTSCLOUD_HPP
