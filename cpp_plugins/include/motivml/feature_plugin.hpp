// The interface a C++ feature plugin implements, and the one line that registers it.
//
//   class Hands : public motivml::FeaturePlugin { ... };
//   MOTIVML_PLUGIN(gestures::Hands)
//
// The plugin is a shared library loaded at run time by ROS class_loader (see
// guidelines/dynamic-features-and-plugins.md). The runtime calls start() off the control
// thread, step() every tick on it, stop() when the feature unloads; an exception from any of
// them is reported (step: the Dynamic feature is unloaded; start: the request is refused).
#ifndef MOTIVML_FEATURE_PLUGIN_HPP
#define MOTIVML_FEATURE_PLUGIN_HPP

#include <string>
#include <vector>

#include <class_loader/register_macro.hpp>

namespace motivml {

// The running architecture's spaces, as a plugin sees them during step().
class Spaces {
 public:
  virtual ~Spaces() = default;
  virtual std::vector<double> read(const std::string& space) = 0;
  // Only spaces no component writes; throws (std::runtime_error) otherwise.
  virtual void write(const std::string& space, const std::vector<double>& value) = 0;
};

class FeaturePlugin {
 public:
  virtual ~FeaturePlugin() = default;
  virtual void start() {}
  virtual void step(double time, Spaces& spaces) = 0;
  virtual void stop() {}
  virtual std::string status() const { return {}; }
};

}  // namespace motivml

// Registers Derived (as written, namespaces included) under the base motivml::FeaturePlugin.
#define MOTIVML_PLUGIN(Derived) CLASS_LOADER_REGISTER_CLASS(Derived, motivml::FeaturePlugin)

#endif  // MOTIVML_FEATURE_PLUGIN_HPP
