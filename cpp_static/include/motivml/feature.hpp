// The one C++ feature interface, for static and dynamic binding alike.
//
//   #include <motivml/feature.hpp>
//   class Hands : public motivml::Feature { ... };
//   MOTIVML_FEATURE(hands, gestures::Hands)
//
// The same source is compiled in through the generated static loader (the variant binds the
// feature Static Early: <motivml_features/hands.hpp> holds it, and the loader calls
// motivml_features::make_hands()) or built as a class_loader plugin by motivml_add_plugin
// (the variant binds it Late or Dynamic: MOTIVML_PLUGIN_BUILD is defined, and the line
// registers the class with class_loader under motivml::Feature). Which one, the variant
// alone decides. Either way the feature is started once, stepped every tick with the time
// and the running architecture's spaces, and stopped once; an exception from start is a
// refused load, from step a fault (a Dynamic feature is unloaded), and status() is what
// the run's summary shows.
#ifndef MOTIVML_FEATURE_HPP
#define MOTIVML_FEATURE_HPP

#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace motivml {

// The running architecture's spaces, as a feature sees them during step().
class Spaces {
 public:
  virtual ~Spaces() = default;
  virtual std::vector<double> read(const std::string& space) = 0;
  // Only spaces no component writes; throws (std::runtime_error) otherwise.
  virtual void write(const std::string& space, const std::vector<double>& value) = 0;
};

class Feature {
 public:
  virtual ~Feature() = default;
  virtual void start() {}
  virtual void step(double time, Spaces& spaces) = 0;
  virtual void stop() {}
  virtual std::string status() const { return {}; }
};

// Spaces held in a map: what a program without motivml's runtime gives its compiled-in
// features (the demo, tests). Reading a space never written is an error, as at run time.
class MapSpaces : public Spaces {
 public:
  std::vector<double> read(const std::string& space) override {
    auto found = values_.find(space);
    if (found == values_.end()) throw std::runtime_error("no space " + space);
    return found->second;
  }
  void write(const std::string& space, const std::vector<double>& value) override { values_[space] = value; }

 private:
  std::map<std::string, std::vector<double>> values_;
};

// The compiled-in features in definition order; started in that order, stopped in reverse.
class FeatureRegistry {
 public:
  void add(std::string id, std::unique_ptr<Feature> feature) {
    ids_.push_back(std::move(id));
    features_.push_back(std::move(feature));
  }
  const std::vector<std::string>& ids() const { return ids_; }
  Feature& at(const std::string& id) {
    for (size_t i = 0; i < ids_.size(); ++i)
      if (ids_[i] == id) return *features_[i];
    throw std::out_of_range("no compiled-in feature " + id);
  }
  void start_all() {
    for (auto& f : features_) f->start();
  }
  void step_all(double time, Spaces& spaces) {
    for (auto& f : features_) f->step(time, spaces);
  }
  void stop_all() {
    for (auto it = features_.rbegin(); it != features_.rend(); ++it) (*it)->stop();
  }

 private:
  std::vector<std::string> ids_;
  std::vector<std::unique_ptr<Feature>> features_;
};

}  // namespace motivml

#ifdef MOTIVML_PLUGIN_BUILD
#include <class_loader/register_macro.hpp>
// A plugin: the class, registered with class_loader under motivml::Feature.
#define MOTIVML_FEATURE(ID, Class) CLASS_LOADER_REGISTER_CLASS(Class, ::motivml::Feature)
#else
// Compiled in: the factory the generated static loader calls.
#define MOTIVML_FEATURE(ID, Class)                                   \
  namespace motivml_features {                                       \
  inline std::unique_ptr<::motivml::Feature> make_##ID() {           \
    return std::unique_ptr<::motivml::Feature>(new Class());          \
  }                                                                  \
  }
#endif

#endif  // MOTIVML_FEATURE_HPP
