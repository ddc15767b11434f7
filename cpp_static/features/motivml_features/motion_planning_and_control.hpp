// SimpleBot's motion_planning_and_control feature, compiled in when the variant binds it Static Early.
#pragma once
#include <motivml_features/simple_feature.hpp>
MOTIVML_SIMPLE_FEATURE(motion_planning_and_control)
