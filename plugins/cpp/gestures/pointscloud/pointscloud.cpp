// The pointscloud plugin: the feature's one source, built by motivml_add_plugin (MOTIVML_PLUGIN_BUILD).
#include <motivml_features/pointscloud.hpp>
