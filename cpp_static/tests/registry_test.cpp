// The registry runs features in definition order and stops them in reverse; a feature sees
// the time and the spaces it is given.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include <motivml/feature.hpp>

namespace {

class Recorder : public motivml::Feature {
 public:
  Recorder(std::string id, std::vector<std::string>* log) : id_(std::move(id)), log_(log) {}
  void start() override { log_->push_back("start " + id_); }
  void step(double time, motivml::Spaces& spaces) override {
    spaces.write(id_, {time});
    log_->push_back("step " + id_ + " " + std::to_string(spaces.read(id_)[0]));
  }
  void stop() override { log_->push_back("stop " + id_); }
  std::string status() const override { return id_ + " ok"; }

 private:
  std::string id_;
  std::vector<std::string>* log_;
};

TEST(FeatureRegistry, StartsInOrderStopsInReverse) {
  std::vector<std::string> log;
  motivml::FeatureRegistry registry;
  registry.add("a", std::make_unique<Recorder>("a", &log));
  registry.add("b", std::make_unique<Recorder>("b", &log));
  motivml::MapSpaces spaces;
  registry.start_all();
  registry.step_all(0.5, spaces);
  registry.stop_all();
  EXPECT_EQ(log, (std::vector<std::string>{"start a", "start b", "step a 0.500000", "step b 0.500000", "stop b",
                                           "stop a"}));
  EXPECT_EQ(registry.ids(), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(registry.at("b").status(), "b ok");
  EXPECT_THROW(registry.at("c"), std::out_of_range);
}

TEST(MapSpaces, ReadingASpaceNeverWrittenIsAnError) {
  motivml::MapSpaces spaces;
  EXPECT_THROW(spaces.read("pose"), std::runtime_error);
  spaces.write("pose", {1.0, 2.0});
  EXPECT_EQ(spaces.read("pose"), (std::vector<double>{1.0, 2.0}));
}

}  // namespace
