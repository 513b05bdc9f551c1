-- gonio results store, schema version 3: the push cycle's phases of a part, s (the station's
-- PhaseTimes: align, approach, push stroke and retract, whose sum is push_s). NULL for parts
-- stored before, whose records did not keep them.

ALTER TABLE parts ADD COLUMN align_s DOUBLE PRECISION;
ALTER TABLE parts ADD COLUMN approach_s DOUBLE PRECISION;
ALTER TABLE parts ADD COLUMN stroke_s DOUBLE PRECISION;
ALTER TABLE parts ADD COLUMN retract_s DOUBLE PRECISION;
