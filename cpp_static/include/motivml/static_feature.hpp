// The interface of a statically bound feature and the registry the generated static
// loader (motivml/static_loader.hpp, written by `motivml configure`) fills.
#ifndef MOTIVML_STATIC_FEATURE_HPP
#define MOTIVML_STATIC_FEATURE_HPP

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace motivml {

// A feature compiled into the program: started once, stepped by the control loop,
// stopped once. Static Early features live as long as the program.
class StaticFeature {
 public:
  virtual ~StaticFeature() = default;
  virtual std::string name() const = 0;
  virtual void start() = 0;
  virtual void step() = 0;
  virtual void stop() = 0;
};

// The compiled-in features in definition order; started in that order, stopped in reverse.
class FeatureRegistry {
 public:
  void add(std::unique_ptr<StaticFeature> feature) { features_.push_back(std::move(feature)); }
  const std::vector<std::unique_ptr<StaticFeature>>& features() const { return features_; }
  void start_all() {
    for (auto& f : features_) f->start();
  }
  void step_all() {
    for (auto& f : features_) f->step();
  }
  void stop_all() {
    for (auto it = features_.rbegin(); it != features_.rend(); ++it) (*it)->stop();
  }

 private:
  std::vector<std::unique_ptr<StaticFeature>> features_;
};

}  // namespace motivml

#endif  // MOTIVML_STATIC_FEATURE_HPP
