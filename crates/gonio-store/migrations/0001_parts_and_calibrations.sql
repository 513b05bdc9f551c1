-- gonio results store, schema version 1: mounting batches, parts, their turns and pushes,
-- recipes, and calibration certificates. Shared by SQLite and PostgreSQL: `{{id}}` is the
-- dialect's auto-increment primary key; every other type is spelled so both accept it.
-- Times are UTC, RFC 3339 text (`2026-05-20T14:03:07.123456Z`), which sorts in time order.
-- A number that is not determined (NaN in the station's record) is NULL.

CREATE TABLE recipes (
    hash TEXT PRIMARY KEY,          -- SHA-256 of the recipe's canonical JSON, hex
    name TEXT NOT NULL,
    recipe_json TEXT NOT NULL
);

CREATE TABLE batches (
    id {{id}},
    station TEXT NOT NULL,
    seed TEXT,                      -- decimal u64, for a simulated station
    config_json TEXT NOT NULL,      -- what was asked for (parts, strategy, recipe, plant, …)
    config_hash TEXT NOT NULL,      -- SHA-256 of config_json: a resumed batch must match it
    parts_planned BIGINT NOT NULL,
    software_version TEXT NOT NULL,
    started_at TEXT NOT NULL,
    ended_at TEXT,
    status TEXT NOT NULL,           -- running | complete | stopped
    stop_reason TEXT
);
CREATE INDEX batches_station_hash ON batches (station, config_hash);

CREATE TABLE parts (
    id {{id}},
    batch_id BIGINT NOT NULL REFERENCES batches (id),
    batch_index BIGINT NOT NULL,    -- 0-based position in its batch
    station TEXT NOT NULL,
    serial TEXT NOT NULL,
    recipe_name TEXT NOT NULL,
    recipe_hash TEXT NOT NULL REFERENCES recipes (hash),
    strategy TEXT NOT NULL,
    software_version TEXT NOT NULL,
    started_at TEXT NOT NULL,
    ended_at TEXT NOT NULL,
    initial_e_um DOUBLE PRECISION,
    final_e_um DOUBLE PRECISION,
    pushes BIGINT NOT NULL,
    time_s DOUBLE PRECISION,
    result TEXT NOT NULL,           -- accepted | rejected_max_pushes | … (PartResult)
    verdict TEXT NOT NULL,          -- pass | reject
    reject_reason TEXT,
    remeasured_turns BIGINT NOT NULL,
    focus_um DOUBLE PRECISION,
    focus_s DOUBLE PRECISION,
    measure_s DOUBLE PRECISION,
    push_s DOUBLE PRECISION,
    device TEXT,                    -- the device whose error ended the part
    device_error_kind TEXT,
    device_error_message TEXT,
    learned_gain DOUBLE PRECISION NOT NULL,          -- the controller's state after the part
    learned_offset_deg DOUBLE PRECISION NOT NULL,
    learned_gain_observations BIGINT NOT NULL,
    learned_offset_observations BIGINT NOT NULL,
    true_initial_e_um DOUBLE PRECISION,              -- simulated parts: the ground truth
    true_final_e_um DOUBLE PRECISION,
    UNIQUE (batch_id, batch_index)
);
CREATE INDEX parts_started_at ON parts (started_at);
CREATE INDEX parts_serial ON parts (serial);
CREATE INDEX parts_verdict ON parts (verdict, result);

CREATE TABLE turns (
    part_id BIGINT NOT NULL REFERENCES parts (id),
    turn_index BIGINT NOT NULL,
    kind TEXT NOT NULL,             -- initial | verify | remeasure
    t_start_s DOUBLE PRECISION,
    frames_taken BIGINT NOT NULL,
    valid_frames BIGINT NOT NULL,
    invalid_frames BIGINT NOT NULL,
    e_um DOUBLE PRECISION,
    u_e_um DOUBLE PRECISION,
    theta_max_deg DOUBLE PRECISION,
    c0_px DOUBLE PRECISION,
    residual_rms_px DOUBLE PRECISION,
    outliers BIGINT NOT NULL,
    focus_um DOUBLE PRECISION,
    quality_ok BIGINT,              -- 1 | 0 | NULL (ring lost: not judged)
    quality_json TEXT,
    samples_json TEXT NOT NULL,     -- [{"theta_deg":…,"c_px":…}, …] of the valid frames
    PRIMARY KEY (part_id, turn_index)
);

CREATE TABLE pushes (
    part_id BIGINT NOT NULL REFERENCES parts (id),
    push_index BIGINT NOT NULL,
    t_start_s DOUBLE PRECISION,
    duration_s DOUBLE PRECISION,
    e_before_um DOUBLE PRECISION,
    e_after_um DOUBLE PRECISION,
    commanded_um DOUBLE PRECISION,  -- the rod's stroke after contact
    angle_deg DOUBLE PRECISION,
    approach TEXT NOT NULL,
    steps BIGINT NOT NULL,
    gain DOUBLE PRECISION,
    predicted_move_um DOUBLE PRECISION,
    predicted_e_after_um DOUBLE PRECISION,
    tolerance_um DOUBLE PRECISION,
    deviation_um DOUBLE PRECISION,
    consistent BIGINT,              -- 1 | 0 | NULL (no trusted verify turn)
    PRIMARY KEY (part_id, push_index)
);

CREATE TABLE calibrations (
    id {{id}},
    item TEXT,
    procedure TEXT NOT NULL,
    method TEXT NOT NULL,
    calibration_date TEXT,
    max_abs_error_arcsec DOUBLE PRECISION NOT NULL,
    max_expanded_arcsec DOUBLE PRECISION,
    source TEXT NOT NULL,
    software_version TEXT NOT NULL,
    stored_at TEXT NOT NULL,
    certificate_json TEXT NOT NULL
);
CREATE INDEX calibrations_item ON calibrations (item);
CREATE INDEX calibrations_date ON calibrations (calibration_date);
CREATE INDEX calibrations_method ON calibrations (method);
