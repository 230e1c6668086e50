function samples = loop_columns(record, samples)
% loop_columns  The loop columns of a record or set struct into a LoopSamples struct (internal to
%   +mdr): displacement and tangential_force, or a torsional record's twist and twisting_moment,
%   whichever fields it has. The service checks that a record holds one pair, not both, and names
%   the column ('samples.twist').
  for name = {'displacement', 'tangential_force', 'twist', 'twisting_moment'}
    if isfield(record, name{1})
      samples.(name{1}) = mdr.internal.json_array(record.(name{1}));
    end
  end
end
