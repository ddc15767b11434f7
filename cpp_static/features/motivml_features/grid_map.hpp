// SimpleBot's grid_map feature, compiled in when the variant binds it Static Early.
#pragma once
#include <motivml_features/simple_feature.hpp>
MOTIVML_SIMPLE_FEATURE(grid_map)
