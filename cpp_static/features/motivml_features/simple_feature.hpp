// A small feature implementation for the examples: it counts its steps and keeps a
// marker string ("motivml-feature:<id>") in the binary, so tests can prove which features
// a build contains.
#ifndef MOTIVML_FEATURES_SIMPLE_FEATURE_HPP
#define MOTIVML_FEATURES_SIMPLE_FEATURE_HPP

#include <iostream>
#include <memory>
#include <string>

#include <motivml/static_feature.hpp>

namespace motivml_features {

class SimpleFeature : public motivml::StaticFeature {
 public:
  SimpleFeature(const char* id, const char* marker) : id_(id), marker_(marker) {}
  std::string name() const override { return id_; }
  void start() override { std::cout << "start " << id_ << "\n"; }
  void step() override { ++steps_; }
  void stop() override { std::cout << "stop " << id_ << " after " << steps_ << " steps\n"; }
  const char* marker() const { return marker_; }

 private:
  std::string id_;
  const char* marker_;
  long steps_ = 0;
};

}  // namespace motivml_features

// Defines motivml_features::make_ID() for a feature with no behaviour of its own.
#define MOTIVML_SIMPLE_FEATURE(ID)                                                    \
  namespace motivml_features {                                                        \
  inline std::unique_ptr<motivml::StaticFeature> make_##ID() {                        \
    return std::make_unique<SimpleFeature>(#ID, "motivml-feature:" #ID);              \
  }                                                                                   \
  }

#endif  // MOTIVML_FEATURES_SIMPLE_FEATURE_HPP
