// Deliberately broken: it uses a variable no library defines, so loading it fails
// (dlopen: undefined symbol), and the runtime must say so with the manifest's location.
#include <string>

#include <motivml/feature.hpp>

extern int motivml_calibration_table_that_nobody_defines;

namespace broken {

class MissingSymbol : public motivml::Feature {
 public:
  void step(double, motivml::Spaces&) override { ++motivml_calibration_table_that_nobody_defines; }
};

}  // namespace broken

MOTIVML_FEATURE(missing_symbol, broken::MissingSymbol)
