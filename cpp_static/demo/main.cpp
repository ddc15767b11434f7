// Lists and runs the features compiled into this build: those the variant binds Static
// Early, registered by the generated static loader.
#include <cstring>
#include <iostream>

#include <motivml/static_loader.hpp>

int main(int argc, char** argv) {
  motivml::FeatureRegistry registry;
  motivml::register_static_features(registry);
  if (argc > 1 && std::strcmp(argv[1], "--list") == 0) {
    for (const auto& id : registry.ids()) std::cout << id << "\n";
    return 0;
  }
  for (const char* const* missing = motivml::unimplemented_features; *missing; ++missing)
    std::cout << "selected without a C++ implementation here: " << *missing << "\n";
  motivml::MapSpaces spaces;
  registry.start_all();
  for (int tick = 0; tick < 100; ++tick) registry.step_all(tick * 0.001, spaces);
  for (const auto& id : registry.ids()) std::cout << id << ": " << registry.at(id).status() << "\n";
  registry.stop_all();
  return 0;
}
