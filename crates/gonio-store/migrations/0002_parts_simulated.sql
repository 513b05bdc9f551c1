-- Whether a part came from the digital twin (1) or a real station (0). Parts stored before
-- this column were the twin's exactly when they carry its ground truth.
ALTER TABLE parts ADD COLUMN simulated BIGINT NOT NULL DEFAULT 0;
UPDATE parts SET simulated = 1 WHERE true_initial_e_um IS NOT NULL;
