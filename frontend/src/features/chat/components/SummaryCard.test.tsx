import { render, screen } from '@testing-library/react';
import { describe, expect, it } from 'vitest';
import { SummaryCard } from './SummaryCard';

const base = {
  kind: 'summary' as const,
  key: 's1',
  missionId: 'm-abc123',
  instruction: 'Fetch the package',
  outcome: 'succeeded',
  summary: 'The package is in the mailroom.',
  steps: [],
};

describe('SummaryCard', () => {
  it('shows the planner tokens and cost of a cloud-planned mission', () => {
    render(<SummaryCard item={{ ...base, usage: { input_tokens: 40_000, output_tokens: 2_100, cost_usd: 0.151 } }} />);
    expect(screen.getByText('Planner: 42,100 tokens · $0.15')).toBeInTheDocument();
  });

  it('shows no usage line for the offline planner', () => {
    render(<SummaryCard item={{ ...base, usage: { input_tokens: 0, output_tokens: 0, cost_usd: null } }} />);
    expect(screen.queryByText(/Planner:/)).toBeNull();
    expect(screen.getByText('The package is in the mailroom.')).toBeInTheDocument();
  });

  it('never shows an internal mission id as the title', () => {
    render(<SummaryCard item={{ ...base, instruction: '' }} />);
    expect(screen.getByRole('heading', { level: 3 })).toHaveTextContent('Mission');
    expect(screen.queryByText(/m-abc123/)).toBeNull();
  });
});
