// A small feature implementation for the examples: it counts its steps and keeps a
// marker string ("motivml-feature:<id>") in the binary, so tests can prove which features
// a build contains.
#ifndef MOTIVML_FEATURES_SIMPLE_FEATURE_HPP
#define MOTIVML_FEATURES_SIMPLE_FEATURE_HPP

#include <iostream>
#include <string>

#include <motivml/feature.hpp>

namespace motivml_features {

class SimpleFeature : public motivml::Feature {
 public:
  SimpleFeature(const char* id, const char* marker) : id_(id), marker_(marker) {}
  void start() override { std::cout << "start " << id_ << "\n"; }
  void step(double, motivml::Spaces&) override { ++steps_; }
  void stop() override { std::cout << "stop " << id_ << " after " << steps_ << " steps\n"; }
  std::string status() const override { return std::to_string(steps_) + " steps"; }
  const char* marker() const { return marker_; }

 private:
  std::string id_;
  const char* marker_;
  long steps_ = 0;
};

}  // namespace motivml_features

// A feature with no behaviour of its own: a class ID_feature, and MOTIVML_FEATURE for it.
#define MOTIVML_SIMPLE_FEATURE(ID)                                                      \
  namespace motivml_features {                                                          \
  struct ID##_feature : SimpleFeature {                                                 \
    ID##_feature() : SimpleFeature(#ID, "motivml-feature:" #ID) {}                       \
  };                                                                                    \
  }                                                                                     \
  MOTIVML_FEATURE(ID, motivml_features::ID##_feature)

#endif  // MOTIVML_FEATURES_SIMPLE_FEATURE_HPP
