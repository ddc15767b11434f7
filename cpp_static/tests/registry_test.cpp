// The registry runs features in definition order and stops them in reverse.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include <motivml/static_feature.hpp>

namespace {

class Recorder : public motivml::StaticFeature {
 public:
  Recorder(std::string id, std::vector<std::string>* log) : id_(std::move(id)), log_(log) {}
  std::string name() const override { return id_; }
  void start() override { log_->push_back("start " + id_); }
  void step() override { log_->push_back("step " + id_); }
  void stop() override { log_->push_back("stop " + id_); }

 private:
  std::string id_;
  std::vector<std::string>* log_;
};

TEST(FeatureRegistry, StartsInOrderStopsInReverse) {
  std::vector<std::string> log;
  motivml::FeatureRegistry registry;
  registry.add(std::make_unique<Recorder>("a", &log));
  registry.add(std::make_unique<Recorder>("b", &log));
  registry.start_all();
  registry.step_all();
  registry.stop_all();
  EXPECT_EQ(log, (std::vector<std::string>{"start a", "start b", "step a", "step b", "stop b", "stop a"}));
  ASSERT_EQ(registry.features().size(), 2u);
  EXPECT_EQ(registry.features()[1]->name(), "b");
}

}  // namespace
