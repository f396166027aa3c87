import csgv_pvtest as t; t.finish()
