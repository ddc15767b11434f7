// Deliberately broken: its static initialiser throws, so dlopen never returns normally. Loaded
// in the running process, the exception would unwind through the dynamic loader and leave its
// lock held (every later load would hang); the runtime must probe it in a child process first
// and refuse it with the manifest's location.
#include <stdexcept>

#include <motivml/feature.hpp>

namespace broken {

struct Calibration {
  Calibration() { throw std::runtime_error("no calibration file"); }
};

const Calibration calibration;  // constructed when the library is loaded

class ThrowingInitialiser : public motivml::Feature {
 public:
  void step(double, motivml::Spaces&) override {}
};

}  // namespace broken

MOTIVML_FEATURE(throwing_initialiser, broken::ThrowingInitialiser)
