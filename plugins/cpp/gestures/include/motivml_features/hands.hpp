// GestureRecognition's Hands feature (stand-in): counts hand gestures in a synthetic stream,
// one every half second from its first step, and reports the last one. One source for both
// bindings: compiled in when the variant binds hands Static Early (the generated static
// loader includes this header), built as a plugin by motivml_add_plugin otherwise (hands.cpp).
#ifndef MOTIVML_FEATURES_HANDS_HPP
#define MOTIVML_FEATURES_HANDS_HPP

#include <cmath>
#include <string>

#include <motivml/feature.hpp>

namespace gestures {

class Hands : public motivml::Feature {
 public:
  void start() override { seen_ = 0; }
  void step(double time, motivml::Spaces&) override {
    if (since_ < 0) since_ = time;
    const int due = static_cast<int>(std::floor((time - since_) * 2.0));
    if (due > seen_) {
      seen_ = due;
      last_ = kGestures[seen_ % 3];
    }
  }
  std::string status() const override {
    return std::to_string(seen_) + (seen_ == 1 ? " hand gesture" : " hand gestures") +
           (seen_ ? ", last: " + last_ : std::string());
  }

 private:
  static constexpr const char* kGestures[3] = {"wave", "stop", "point"};
  double since_ = -1.0;
  int seen_ = 0;
  std::string last_;
};

}  // namespace gestures

MOTIVML_FEATURE(hands, gestures::Hands)

#endif  // MOTIVML_FEATURES_HANDS_HPP
