// Deliberately broken: it uses a variable no library defines, so loading it fails
// (dlopen: undefined symbol), and the runtime must say so with the manifest's location.
#include <string>

#include "motivml/feature_plugin.hpp"

extern int motivml_calibration_table_that_nobody_defines;

namespace broken {

class MissingSymbol : public motivml::FeaturePlugin {
 public:
  void step(double, motivml::Spaces&) override { ++motivml_calibration_table_that_nobody_defines; }
};

}  // namespace broken

MOTIVML_PLUGIN(broken::MissingSymbol)
