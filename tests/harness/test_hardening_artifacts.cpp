#include <gtest/gtest.h>

#include "cli_test_util.h"
