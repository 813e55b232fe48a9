#include "talus/core/settings.hpp"
